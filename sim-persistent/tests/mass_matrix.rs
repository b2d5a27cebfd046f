//! The state-dependent segment mass matrix (physics notes, seed 000 §3.2) against first
//! principles: the kinetic energy `½ ∫ ρ |∂x(s)/∂t|² ds` of the material between the ends of a
//! sliding segment, with the material velocity at fixed arc length `s` taken by central
//! differences in time of `x(s; q) = (1 − t) x₀ + t x₁`, `t = (s − u₀)/(u₁ − u₀)`, and the
//! integral by 3-point Gauss–Legendre (exact for the quadratic integrand).

use nalgebra::SVector;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use sim_persistent::state::segment_mass_matrix;

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x000c_1211),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Position of the material point of arc length `s` on the segment `q = (x₀, u₀, x₁, u₁)`.
fn material_point(q: &SVector<f64, 8>, s: f64) -> nalgebra::Vector3<f64> {
    let t = (s - q[3]) / (q[7] - q[3]);
    (1.0 - t) * q.fixed_rows::<3>(0) + t * q.fixed_rows::<3>(4)
}

fn kinetic_by_quadrature(rho: f64, q: &SVector<f64, 8>, qdot: &SVector<f64, 8>) -> f64 {
    let (u0, u1) = (q[3], q[7]);
    let (mid, half) = (0.5 * (u0 + u1), 0.5 * (u1 - u0));
    let r = (0.6f64).sqrt();
    let eps = 1e-7;
    [(-r, 5.0 / 9.0), (0.0, 8.0 / 9.0), (r, 5.0 / 9.0)]
        .iter()
        .map(|&(xi, w)| {
            let s = mid + half * xi;
            let v = (material_point(&(q + eps * qdot), s) - material_point(&(q - eps * qdot), s))
                / (2.0 * eps);
            w * half * 0.5 * rho * v.norm_squared()
        })
        .sum()
}

fn vec8() -> impl Strategy<Value = [f64; 8]> {
    proptest::array::uniform8(-1.0..1.0f64)
}

proptest! {
    #![proptest_config(config(64))]

    #[test]
    fn kinetic_energy_matches_the_material_integral(a in vec8(), b in vec8(), du in 0.3..2.0f64) {
        let l = 1e-3;
        let mut q = SVector::<f64, 8>::from_column_slice(&a) * l;
        q[7] = q[3] + du * l;
        let qdot = SVector::<f64, 8>::from_column_slice(&b) * 0.1; // m/s
        let rho = 1.7e-3;
        let m = segment_mass_matrix(rho, &q);
        let t_matrix = 0.5 * qdot.dot(&(m * qdot));
        let t_quad = kinetic_by_quadrature(rho, &q, &qdot);
        prop_assert!((t_matrix - t_quad).abs() <= 1e-6 * t_quad.abs().max(1e-300),
            "matrix {t_matrix:e} vs quadrature {t_quad:e}");
        // Symmetric, and positive semi-definite with the two null motions (w δ, δ) per end.
        prop_assert!((m - m.transpose()).amax() == 0.0);
        let w = (q.fixed_rows::<3>(4) - q.fixed_rows::<3>(0)) / (q[7] - q[3]);
        for end in [0usize, 4] {
            let mut z = SVector::<f64, 8>::zeros();
            z.fixed_rows_mut::<3>(end).copy_from(&w);
            z[end + 3] = 1.0;
            prop_assert!((m * z).amax() <= 1e-12 * m.amax());
        }
        let eig = rod::spd::symmetric_eigenvalues(m.as_slice(), 8);
        prop_assert!(eig[0] >= -1e-12 * m.amax());
    }
}
