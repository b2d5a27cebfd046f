//! The pear-loop bending test: the loop converges from 3.4 cm down to 0.3 cm clamp distance,
//! and its shape depends on the bending stiffness through gravity.

use shell_fem::elements::BendingParams;
use shell_fem::material::{InPlaneParams, Material};
use shell_fem::pear_loop::{PearLoop, PearLoopConfig};

fn sweep(k: f64) -> Vec<shell_fem::pear_loop::LoopShape> {
    let cfg = PearLoopConfig {
        nx: 24,
        ny: 1,
        max_step: 0.006,
        ..PearLoopConfig::default()
    };
    let b = BendingParams {
        weft: k,
        bias: k,
        warp: k,
    };
    let mut l = PearLoop::new(
        &cfg,
        Material::augmented(InPlaneParams::example()),
        b,
        0.0,
        0.034,
    )
    .unwrap();
    let mut out = vec![l.shape()];
    for i in 1..7 {
        let d = 0.034 - (0.034 - 0.003) * i as f64 / 6.0;
        out.push(l.solve_to(d).unwrap());
    }
    out
}

#[test]
fn pear_loop_sweeps_and_depends_on_bending_stiffness() {
    let stiff = sweep(1e-6);
    let soft = sweep(1e-7);
    for (a, b) in stiff.iter().zip(&soft) {
        println!(
            "d {:.4}: stiff r {:.4} (h {:.4}, p {:.4}); soft r {:.4} (h {:.4}, p {:.4})",
            a.d, a.ratio, a.height, a.width, b.ratio, b.height, b.width
        );
        assert!(a.ratio.is_finite() && b.ratio.is_finite());
        assert!(a.width >= a.d - 1e-12 && b.width >= b.d - 1e-12);
    }
    // Gravity stretches a soft loop downwards: taller relative to its width.
    assert!(soft.last().unwrap().ratio > stiff.last().unwrap().ratio);
}
