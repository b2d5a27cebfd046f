//! Total derivatives of the equilibrium stress (implicit differentiation through the
//! constrained Newton system) against central differences of re-solved equilibria.

use nalgebra::{Matrix2, Vector2};
use sim_periodic::coarse::Coarse;
use sim_periodic::fit::{Parameter, parameter_partial};
use sim_periodic::patterns::{Pattern, RelaxSettings, relax};
use sim_periodic::periodic::{
    Equilibrium, EquilibriumSettings, YarnModel, equilibrium_problem, solve_equilibrium,
    stress_sensitivities,
};
use yarn_pattern::tile::Tile;

fn tight() -> EquilibriumSettings {
    let mut s = EquilibriumSettings::default();
    s.newton.gradient_abs_tol = 1e-13;
    s.newton.gradient_rel_tol = 1e-13;
    s
}

fn solve(tile: &Tile, model: &YarnModel, coarse: Coarse, warm: Option<&[f64]>) -> Equilibrium {
    solve_equilibrium(tile, model, coarse, warm, &tight()).unwrap()
}

/// Largest entry difference relative to the largest entry of `b`.
fn rel(a: &Matrix2<f64>, b: &Matrix2<f64>) -> f64 {
    (a - b).amax() / b.amax()
}

#[test]
fn stress_sensitivities_match_central_differences_of_resolved_equilibria() {
    let radius = 1e-3;
    let model = YarnModel::default_for_radius(radius);
    let p = Pattern::Stockinette;
    let guess = p.generate(&p.default_params(radius)).unwrap();
    let (tile, _) = relax(&guess, &model, &RelaxSettings::default()).unwrap();
    let (s, c, angle) = (0.25, 0.08, 0.3);
    let coarse = Coarse::uniaxial(s, c, angle);
    let eq = solve(&tile, &model, coarse, None);
    let problem = equilibrium_problem(&tile, &model, &eq).unwrap();

    // The compression c: F moves by −v vᵀ per unit c.
    let v = Vector2::new(-angle.sin(), angle.cos());
    let d_f = -(v * v.transpose());
    let mut partials = vec![problem.coarse_partial(&eq.dofs, &d_f).unwrap()];
    // The yarn model's parameters; the geometric ones act on the input geometry before the
    // rest-shape estimation, so at a given tile their partials are exactly zero.
    let (geometric, parameters): (Vec<Parameter>, Vec<Parameter>) =
        Parameter::ALL.into_iter().partition(|p| p.is_geometric());
    for &parameter in &geometric {
        let partial = parameter_partial(&tile, &model, &eq, parameter).unwrap();
        assert!(partial.gradient.iter().all(|g| *g == 0.0) && partial.stress == Matrix2::zeros());
    }
    for &parameter in &parameters {
        partials.push(parameter_partial(&tile, &model, &eq, parameter).unwrap());
    }
    let total = stress_sensitivities(&problem, &eq.dofs, &partials).unwrap();

    // Compression: re-solve at c ± h.
    let h = 1e-5;
    let plus = solve(
        &tile,
        &model,
        Coarse::uniaxial(s, c + h, angle),
        Some(&eq.dofs),
    );
    let minus = solve(
        &tile,
        &model,
        Coarse::uniaxial(s, c - h, angle),
        Some(&eq.dofs),
    );
    let fd = (plus.stress - minus.stress) / (2.0 * h);
    eprintln!("dP/dc: implicit {}, central differences {fd}", total[0]);
    assert!(
        rel(&total[0], &fd) < 1e-5,
        "dP/dc off by {:e}",
        rel(&total[0], &fd)
    );

    // Parameters: re-solve with p ± h p.
    for (k, &parameter) in parameters.iter().enumerate() {
        let value = parameter.get(&model);
        let h = 1e-5 * value;
        let shifted = |delta: f64| {
            let m = set(model, parameter, value + delta);
            solve(&tile, &m, coarse, Some(&eq.dofs)).stress
        };
        let fd = (shifted(h) - shifted(-h)) / (2.0 * h);
        let err = rel(&total[k + 1], &fd);
        eprintln!(
            "dP/d{}: implicit {}, central differences {fd}, relative difference {err:.2e}",
            parameter.name(),
            total[k + 1]
        );
        assert!(err < 1e-4, "dP/d{} off by {err:e}", parameter.name());
    }
}

/// `model` with `parameter` at `value` (the twist stiffness following the bending one).
fn set(mut model: YarnModel, parameter: Parameter, value: f64) -> YarnModel {
    match parameter {
        Parameter::StretchSoft => {
            if let rod::stretch::StretchLaw::TwoPhase { k1, .. } = &mut model.stretch {
                *k1 = value;
            }
        }
        Parameter::Onset => {
            if let rod::stretch::StretchLaw::TwoPhase { onset, .. } = &mut model.stretch {
                *onset = value;
            }
        }
        Parameter::Bending => {
            model.twist *= value / model.bending;
            model.bending = value;
        }
        Parameter::ContactRadius => model.contact[0].radius = value,
        Parameter::ContactStiffness => model.contact[0].stiffness = value,
        Parameter::StretchStiff => {
            if let rod::stretch::StretchLaw::TwoPhase { k2, .. } = &mut model.stretch {
                *k2 = value;
            }
        }
        Parameter::GeometryX | Parameter::GeometryY => unreachable!("not a model parameter"),
    }
    model
}
