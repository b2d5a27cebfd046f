//! `rod` + `solver` against closed forms: a clamped discrete elastic rod under a tip load
//! matches Euler–Bernoulli `PL³/(3EI)` within 1 % at ≥ 50 segments for small loads, and the
//! elastica for large ones.

use solver::validation::cantilever::{Beam, elastica_tip, sweep};

#[test]
fn cantilever_matches_euler_bernoulli_within_one_percent_at_small_loads() {
    let beam = Beam::default();
    for segments in [50, 100] {
        for alpha in [0.003, 0.01, 0.03] {
            let p = &sweep(&beam, segments, &[alpha]).expect("Newton converges")[0];
            let tip_m = p.deflection * beam.length;
            let linear_m = beam.linear_tip_deflection(beam.load_for(alpha));
            let err = (tip_m - linear_m).abs() / linear_m;
            println!(
                "{segments} segments, α = {alpha}: tip {tip_m:.6e} m vs PL³/3EI {linear_m:.6e} m, error {:.4} %",
                100.0 * err
            );
            assert!(err < 0.01, "error {err} ≥ 1 %");
        }
    }
}

#[test]
fn cantilever_follows_the_elastica_at_large_deflection() {
    let beam = Beam::default();
    let alphas: Vec<f64> = (1..=30).map(|i| 0.1 * i as f64).collect();
    let points = sweep(&beam, 100, &alphas).expect("Newton converges along the load ramp");
    for p in points.iter().step_by(5) {
        let (d, r) = elastica_tip(p.alpha).expect("elastica reference");
        println!(
            "α = {:.1}: δ/L {:.5} (elastica {:.5}), retraction/L {:.5} (elastica {:.5})",
            p.alpha, p.deflection, d, p.retraction, r
        );
        assert!(
            (p.deflection - d).abs() < 2e-3 * d,
            "deflection off the elastica at α = {}",
            p.alpha
        );
        assert!(
            (p.retraction - r).abs() < 1e-2 * r.max(1e-3),
            "retraction off the elastica at α = {}",
            p.alpha
        );
    }
    // Linear theory is far off at α = 3: the test would notice a solver that stayed linear.
    let last = points.last().unwrap();
    assert!(last.deflection < 0.75 * last.alpha / 3.0);
}
