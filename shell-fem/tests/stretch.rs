//! The virtual stretch test: mesh refinement, stability at extreme stretches, adjoint
//! sensitivities against re-solved finite differences, and agreement of sliding clamps with the
//! uniform curves of Eq. 3.

use shell_fem::curves::uniaxial_curve;
use shell_fem::material::{InPlaneParams, Material};
use shell_fem::swatch::{Clamp, StretchTest, SwatchConfig};
use yarn_pattern::direction::Direction;

fn material() -> Material {
    Material::augmented(InPlaneParams::example())
}

#[test]
fn two_uniform_subdivisions_change_force_and_compression_by_at_most_one_percent() {
    for dir in [Direction::Weft, Direction::Bias] {
        let run = |subdivisions| {
            let cfg = SwatchConfig {
                subdivisions,
                ..SwatchConfig::default()
            };
            let mut t = StretchTest::new(&cfg, material(), dir.angle()).unwrap();
            t.solve_to(0.4).unwrap()
        };
        let (coarse, fine) = (run(0), run(2));
        let df = (coarse.force - fine.force).abs() / fine.force;
        let dc = (coarse.compression - fine.compression).abs() / fine.compression;
        println!("{dir:?}: coarse {coarse:?}\n  fine {fine:?}\n  Δf {df:.4} Δc {dc:.4}");
        assert!(fine.force > 0.0 && fine.compression > 0.0);
        assert!(df <= 0.01, "{dir:?}: force changed by {:.3} %", 100.0 * df);
        assert!(
            dc <= 0.01,
            "{dir:?}: compression changed by {:.3} %",
            100.0 * dc
        );
    }
}

#[test]
fn extreme_stretch_and_compression_converge_or_fail_loudly() {
    for model in [
        Material::augmented(InPlaneParams::example()),
        Material::stvk(InPlaneParams::example()),
    ] {
        for dir in Direction::ALL {
            for s in [3.0, -0.5] {
                let cfg = SwatchConfig {
                    nx: 10,
                    ny: 6,
                    max_halvings: 3,
                    ..SwatchConfig::default()
                };
                let mut t = StretchTest::new(&cfg, model, dir.angle()).unwrap();
                let t0 = std::time::Instant::now();
                let r = t.solve_to(s);
                println!(
                    "{:?} {dir:?} s = {s}: {:?} ({:.2} s)",
                    model.model,
                    r.as_ref()
                        .map(|p| (p.force, p.compression))
                        .map_err(|e| e.to_string()),
                    t0.elapsed().as_secs_f64()
                );
                match r {
                    Ok(p) => {
                        assert!(p.force.is_finite() && p.compression.is_finite());
                        assert!(t.positions().iter().all(|v| v.is_finite()));
                        assert_eq!(p.s, s);
                        // Pulling needs a positive force, pushing a negative one.
                        assert_eq!(p.force > 0.0, s > 0.0, "{model:?} {dir:?} s = {s}: {p:?}");
                    }
                    Err(e) => {
                        let msg = e.to_string();
                        assert!(msg.contains("equilibrium not reached"), "{msg}");
                    }
                }
            }
        }
    }
}

#[test]
fn adjoint_sensitivities_match_resolved_finite_differences() {
    let cfg = SwatchConfig {
        nx: 10,
        ny: 6,
        ..SwatchConfig::default()
    };
    let p0 = InPlaneParams::example();
    for dir in [Direction::Weft, Direction::Bias] {
        let mut t = StretchTest::new(&cfg, Material::augmented(p0), dir.angle()).unwrap();
        t.solve_to(0.3).unwrap();
        let sens = t.sensitivities().unwrap();
        let x0 = t.positions().to_vec();
        for k in 0..6 {
            let h = 1e-5 * p0.to_array()[k];
            let mut at = |sign: f64| {
                let mut p = p0.to_array();
                p[k] += sign * h;
                t.set_material(Material::augmented(InPlaneParams::from_array(p)));
                t.set_state(0.3, &x0).unwrap();
                t.solve_to(0.3).unwrap()
            };
            let (plus, minus) = (at(1.0), at(-1.0));
            let fd_f = (plus.force - minus.force) / (2.0 * h);
            let fd_c = (plus.compression - minus.compression) / (2.0 * h);
            let scale_f = sens.force.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let scale_c = sens.compression.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(
                (fd_f - sens.force[k]).abs() <= 1e-5 * scale_f,
                "{dir:?} df/dp{k}: adjoint {} fd {fd_f}",
                sens.force[k]
            );
            assert!(
                (fd_c - sens.compression[k]).abs() <= 1e-5 * scale_c,
                "{dir:?} dc/dp{k}: adjoint {} fd {fd_c}",
                sens.compression[k]
            );
        }
    }
}

#[test]
fn sliding_clamps_agree_with_uniform_curves() {
    let m = material();
    for dir in [Direction::Weft, Direction::Warp] {
        let cfg = SwatchConfig {
            clamp: Clamp::Sliding,
            nx: 10,
            ny: 6,
            ..SwatchConfig::default()
        };
        let mut t = StretchTest::new(&cfg, m, dir.angle()).unwrap();
        let stretches = [0.1, 0.3, 0.6];
        let uniform = uniaxial_curve(&m, dir.angle(), &stretches).unwrap();
        for (s, u) in stretches.iter().zip(&uniform) {
            let p = t.solve_to(*s).unwrap();
            let f_uniform = u.sigma * cfg.width;
            assert!(
                (p.force - f_uniform).abs() <= 0.01 * f_uniform,
                "{dir:?} s = {s}: {} vs {f_uniform}",
                p.force
            );
            assert!(
                (p.compression - u.c).abs() <= 0.01 * u.c.abs(),
                "{dir:?} s = {s}: {} vs {}",
                p.compression,
                u.c
            );
        }
    }
}
