//! The 3-D shell (membrane + edge hinges + gravity) through the `solver` Newton: a strip
//! clamped along one short edge sags under gravity, less for stiffer bending.

use shell_fem::elements::BendingParams;
use shell_fem::material::{InPlaneParams, Material};
use shell_fem::shell::{Gravity, Shell, ShellOptions, TriMesh};
use solver::{NewtonSettings, minimize};

/// Tip deflection (m, positive down) of a 6 cm × 2 cm strip clamped along x = 0 (two node
/// columns, so the clamp also fixes the slope).
pub fn sag(k_theta: f64) -> f64 {
    let mesh = TriMesh::rectangle(0.06, 0.02, 12, 4).unwrap();
    let opts = ShellOptions {
        dim: 3,
        bending: Some(BendingParams {
            weft: k_theta,
            bias: k_theta,
            warp: k_theta,
        }),
        gravity: Some(Gravity {
            areal_density: 0.2,
            g: 9.81,
        }),
    };
    let shell = Shell::new(&mesh, Material::augmented(InPlaneParams::example()), opts).unwrap();
    let mut x = shell.positions_from_rest(&mesh.rest);
    let fixed: Vec<bool> = (0..x.len()).map(|d| mesh.rest[d / 3][0] < 0.0051).collect();
    let report = minimize(
        &shell,
        &mut x,
        &fixed,
        &NewtonSettings {
            gradient_abs_tol: 1e-12,
            ..NewtonSettings::default()
        },
    )
    .unwrap();
    assert!(report.converged());
    assert!(x.iter().all(|v| v.is_finite()));
    // Mean z of the free-end nodes.
    let tip: Vec<f64> = (0..mesh.rest.len())
        .filter(|&v| (mesh.rest[v][0] - 0.06).abs() < 1e-12)
        .map(|v| x[3 * v + 2])
        .collect();
    -tip.iter().sum::<f64>() / tip.len() as f64
}

#[test]
fn strip_sags_under_gravity_and_stiffer_bending_sags_less() {
    let soft = sag(2e-6);
    let stiff = sag(2e-5);
    println!("sag: soft {soft:.4e} m, stiff {stiff:.4e} m");
    assert!(soft > 0.0 && stiff > 0.0);
    assert!(soft > 2.0 * stiff, "soft {soft}, stiff {stiff}");
    // A sag below the strip length: the clamp holds.
    assert!(soft < 0.06);
}

#[test]
fn effective_bending_rigidity_of_the_hinge_model() {
    // Small-deflection cantilever: δ = q L⁴ / (8 B w) with q = ρ g w, so B = ρ g L⁴ / (8 δ)
    // is the bending rigidity per unit width (N·m) the discrete model shows; compare with
    // 2 k_θ, the rigidity that Ψ_b = k_θ κ² would give with κ the true curvature.
    let k = 2e-4;
    let delta = sag(k);
    let free: f64 = 0.06 - 0.005;
    let b = 0.2 * 9.81 * free.powi(4) / (8.0 * delta);
    let ratio = b / (2.0 * k);
    println!(
        "δ = {delta:.4e} m (δ/L = {:.4}), B/(2k) = {ratio:.3}",
        delta / free
    );
    assert!(delta / free < 0.03, "not in the small-deflection regime");
    assert!(ratio > 1.0 && ratio < 20.0);
}
