//! The optimized yarn parameters and their bounds (seed 002 §7.3.2).
//!
//! The paper optimizes `p = {k_s1, Ȳ_s, k_b, R₁, k_c1}`: the soft stretch stiffness, the onset of
//! the stiff regime, the bending stiffness, the outer contact radius and its stiffness. The
//! stiff stretch stiffness `k_s2` is an input (the stiffest yarn's), the inner contact is a
//! non-penetration core with `R₂ = R_est / 4` and a fixed stiffness. Bounds, from the
//! geometric base radius `R_est` ([`estimated_radius`]):
//!
//! ```text
//! k_s1 ∈ [1e-3 k_s2, k_s2]          (log)
//! Ȳ_s  ∈ [0, 0.15]
//! k_b  ∈ [1e-3, 10] k_s2 R_est² / 4  (log)
//! R₁   ∈ [0.5, 1.5] R_est
//! k_c1 ∈ [1e-5, 1e-1] k_c2           (log)
//! ```
//!
//! The paper states `k_c1 ∈ [1e-2, 1e2]` with `k_c2 = 1e3` in its units; here the range is
//! kept as the same ratio to `k_c2` (J/m², whose default is `1e6` for a 1 mm yarn), since the
//! absolute value depends on the length unit. The twist stiffness, not a parameter of the
//! paper's isotropic rods, follows the bending stiffness with the base model's ratio `k_t/k_b`.
//!
//! Beyond the paper, `k_s2` can be freed too ([`Parameter::StretchStiff`]); the paper's space
//! keeps it fixed. Also beyond the paper, the input geometry itself can be stretched along x
//! and y before the rest-shape estimation ([`Parameter::GeometryX`], [`Parameter::GeometryY`],
//! [`ParameterSpace::geometry_stretch`]): the paper starts from hand-registered yarn geometry
//! of each fabric (§4.2), where a procedural tile only guesses the loops' proportions.
//!
//! The optimizers see every parameter normalized to `[0, 1]` (log-scaled ones in log space).

use crate::coarse::Coarse;
use crate::periodic::{Equilibrium, Partial, PeriodicTile, YarnModel, equilibrium_problem};
use rod::contact::closest_points;
use rod::stretch::StretchLaw;
use yarn_pattern::tile::Tile;

use super::FitError;

/// One optimizable yarn parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Parameter {
    /// Soft stretch stiffness `k_s1` (N); `k` of a linear stretch law.
    StretchSoft,
    /// Onset strain `Ȳ_s` of the stiff stretch regime (two-phase law only).
    Onset,
    /// Bending stiffness `k_b` (N·m²); the twist stiffness keeps its ratio to it.
    Bending,
    /// Outer (soft) contact radius `R₁` (m).
    ContactRadius,
    /// Outer (soft) contact stiffness `k_c1` (J/m²).
    ContactStiffness,
    /// Stiff stretch stiffness `k_s2` (N) of the two-phase law. **Beyond the paper**, which
    /// takes it as an input (the stiffest yarn's); not in [`ParameterSpace::paper`], free only
    /// when listed (the CLI's `[parameters] k2 = [min, max]`).
    StretchStiff,
    /// Stretch factor (unitless, > 0) of the input geometry along x (the course: weft) before
    /// the rest-shape estimation: positions and period `x → a x`, the rest shape reset to the
    /// stretched geometry ([`stretched_geometry`]). **Beyond the paper**, which registers each
    /// fabric's geometry by hand (§4.2); not in [`ParameterSpace::paper`].
    GeometryX,
    /// Stretch factor of the input geometry along y (the wale: warp); as
    /// [`Parameter::GeometryX`].
    GeometryY,
}

impl Parameter {
    /// All parameters: the paper's five in its order, then `k_s2`, then the geometry's
    /// stretch factors.
    pub const ALL: [Parameter; 8] = [
        Parameter::StretchSoft,
        Parameter::Onset,
        Parameter::Bending,
        Parameter::ContactRadius,
        Parameter::ContactStiffness,
        Parameter::StretchStiff,
        Parameter::GeometryX,
        Parameter::GeometryY,
    ];

    /// The name used in configs and reports.
    pub fn name(self) -> &'static str {
        match self {
            Parameter::StretchSoft => "k1",
            Parameter::Onset => "onset",
            Parameter::Bending => "bending",
            Parameter::ContactRadius => "contact_radius",
            Parameter::ContactStiffness => "contact_stiffness",
            Parameter::StretchStiff => "k2",
            Parameter::GeometryX => "geometry_x",
            Parameter::GeometryY => "geometry_y",
        }
    }

    /// Whether it stretches the input geometry ([`Parameter::GeometryX`],
    /// [`Parameter::GeometryY`]) rather than setting a value of the yarn model.
    pub fn is_geometric(self) -> bool {
        matches!(self, Parameter::GeometryX | Parameter::GeometryY)
    }

    /// The parameter called `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Whether it is searched in log space (the paper: `k_s1`, `k_b`, `k_c1`).
    pub fn log_scale(self) -> bool {
        matches!(
            self,
            Parameter::StretchSoft
                | Parameter::Bending
                | Parameter::ContactStiffness
                | Parameter::StretchStiff
        )
    }

    /// Its value in `model`; a geometric parameter is not part of the model and reads 1 (the
    /// unstretched input geometry).
    pub fn get(self, model: &YarnModel) -> f64 {
        match self {
            Parameter::StretchSoft => match model.stretch {
                StretchLaw::Linear { k } => k,
                StretchLaw::TwoPhase { k1, .. } => k1,
            },
            Parameter::Onset => match model.stretch {
                StretchLaw::Linear { .. } => 0.0,
                StretchLaw::TwoPhase { onset, .. } => onset,
            },
            Parameter::Bending => model.bending,
            Parameter::ContactRadius => model.contact[0].radius,
            Parameter::ContactStiffness => model.contact[0].stiffness,
            Parameter::StretchStiff => match model.stretch {
                StretchLaw::Linear { .. } => 0.0,
                StretchLaw::TwoPhase { k2, .. } => k2,
            },
            Parameter::GeometryX | Parameter::GeometryY => 1.0,
        }
    }

    /// `model` with this parameter set to `value` (a geometric parameter leaves it as it is).
    fn set(self, model: &mut YarnModel, value: f64) {
        match self {
            Parameter::StretchSoft => match &mut model.stretch {
                StretchLaw::Linear { k } => *k = value,
                StretchLaw::TwoPhase { k1, .. } => *k1 = value,
            },
            Parameter::Onset => {
                if let StretchLaw::TwoPhase { onset, .. } = &mut model.stretch {
                    *onset = value;
                }
            }
            Parameter::Bending => {
                let ratio = if model.bending > 0.0 {
                    model.twist / model.bending
                } else {
                    0.0
                };
                model.bending = value;
                model.twist = ratio * value;
            }
            Parameter::ContactRadius => model.contact[0].radius = value,
            Parameter::ContactStiffness => model.contact[0].stiffness = value,
            Parameter::StretchStiff => {
                if let StretchLaw::TwoPhase { k2, .. } = &mut model.stretch {
                    *k2 = value;
                }
            }
            Parameter::GeometryX | Parameter::GeometryY => {}
        }
    }
}

/// A free parameter and its search interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bound {
    /// The parameter.
    pub parameter: Parameter,
    /// Lower end (SI).
    pub min: f64,
    /// Upper end (SI).
    pub max: f64,
}

/// The search space: a base model and the free parameters with their bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterSpace {
    /// The model whose other values are kept.
    pub base: YarnModel,
    /// The free parameters, each at most once.
    pub free: Vec<Bound>,
}

impl ParameterSpace {
    /// The paper's five parameters with the bounds of the module documentation, around
    /// `base` (whose `k_s2`, `k_c2` are the fixed inputs) and the base radius `r_est` (m). The
    /// inner contact radius of the result is `R₂ = r_est / 4`. With a linear stretch law the
    /// onset is not a parameter.
    pub fn paper(base: &YarnModel, r_est: f64) -> Result<Self, FitError> {
        if !(r_est.is_finite() && r_est > 0.0) {
            return Err(FitError::Invalid(format!(
                "the base radius R_est must be positive, found {r_est}"
            )));
        }
        let mut base = *base;
        base.contact[1].radius = 0.25 * r_est;
        let k2 = match base.stretch {
            StretchLaw::Linear { k } => k,
            StretchLaw::TwoPhase { k2, .. } => k2,
        };
        let kb_base = k2 * r_est * r_est / 4.0;
        let kc2 = base.contact[1].stiffness;
        let mut free = vec![Bound {
            parameter: Parameter::StretchSoft,
            min: 1e-3 * k2,
            max: k2,
        }];
        if matches!(base.stretch, StretchLaw::TwoPhase { .. }) {
            free.push(Bound {
                parameter: Parameter::Onset,
                min: 0.0,
                max: 0.15,
            });
        }
        free.extend([
            Bound {
                parameter: Parameter::Bending,
                min: 1e-3 * kb_base,
                max: 10.0 * kb_base,
            },
            Bound {
                parameter: Parameter::ContactRadius,
                min: 0.5 * r_est,
                max: 1.5 * r_est,
            },
            Bound {
                parameter: Parameter::ContactStiffness,
                min: 1e-5 * kc2,
                max: 1e-1 * kc2,
            },
        ]);
        Self::new(base, free)
    }

    /// Checks and builds a space: every bound finite with `min < max` (`min > 0` on log
    /// scale), no parameter twice, no onset with a linear stretch law.
    pub fn new(base: YarnModel, free: Vec<Bound>) -> Result<Self, FitError> {
        for (i, b) in free.iter().enumerate() {
            let name = b.parameter.name();
            if !(b.min.is_finite() && b.max.is_finite() && b.min < b.max) {
                return Err(FitError::Invalid(format!(
                    "parameter {name}: need finite bounds with min < max, found [{}, {}]",
                    b.min, b.max
                )));
            }
            if b.parameter.log_scale() && b.min <= 0.0 {
                return Err(FitError::Invalid(format!(
                    "parameter {name} is searched in log space: its lower bound must be \
                     positive, found {}",
                    b.min
                )));
            }
            if b.parameter.is_geometric() && b.min <= 0.0 {
                return Err(FitError::Invalid(format!(
                    "parameter {name} stretches the geometry: its lower bound must be \
                     positive, found {}",
                    b.min
                )));
            }
            if free[..i].iter().any(|o| o.parameter == b.parameter) {
                return Err(FitError::Invalid(format!(
                    "parameter {name} is listed twice"
                )));
            }
            if matches!(b.parameter, Parameter::Onset | Parameter::StretchStiff)
                && matches!(base.stretch, StretchLaw::Linear { .. })
            {
                return Err(FitError::Invalid(format!(
                    "parameter {name} needs the two-phase stretch law (the model's is linear)"
                )));
            }
        }
        if free.is_empty() {
            return Err(FitError::Invalid("no parameter to fit".into()));
        }
        Ok(Self { base, free })
    }

    /// Number of free parameters.
    pub fn dim(&self) -> usize {
        self.free.len()
    }

    /// The model at the normalized point `x ∈ [0, 1]ⁿ` (clamped into the box).
    pub fn model(&self, x: &[f64]) -> YarnModel {
        let mut m = self.base;
        for (b, &t) in self.free.iter().zip(x) {
            b.parameter.set(&mut m, denormalize(b, t.clamp(0.0, 1.0)));
        }
        m
    }

    /// The stretch factors `[a_x, a_y]` of the input geometry at the normalized point `x`
    /// ([`Parameter::GeometryX`], [`Parameter::GeometryY`]; 1 where not free).
    pub fn geometry_stretch(&self, x: &[f64]) -> [f64; 2] {
        let mut stretch = [1.0, 1.0];
        for (b, v) in self.free.iter().zip(self.values(x)) {
            match b.parameter {
                Parameter::GeometryX => stretch[0] = v,
                Parameter::GeometryY => stretch[1] = v,
                _ => {}
            }
        }
        stretch
    }

    /// The parameter values (SI) at the normalized point `x`.
    pub fn values(&self, x: &[f64]) -> Vec<f64> {
        self.free
            .iter()
            .zip(x)
            .map(|(b, &t)| denormalize(b, t.clamp(0.0, 1.0)))
            .collect()
    }

    /// The normalized point of `model`'s free parameters (not clamped: outside `[0, 1]` when
    /// the model is outside the box).
    pub fn normalized(&self, model: &YarnModel) -> Vec<f64> {
        self.free
            .iter()
            .map(|b| {
                let v = b.parameter.get(model);
                if b.parameter.log_scale() {
                    (v.ln() - b.min.ln()) / (b.max.ln() - b.min.ln())
                } else {
                    (v - b.min) / (b.max - b.min)
                }
            })
            .collect()
    }
}

fn denormalize(b: &Bound, t: f64) -> f64 {
    if b.parameter.log_scale() {
        (b.min.ln() + t * (b.max.ln() - b.min.ln())).exp()
    } else {
        b.min + t * (b.max - b.min)
    }
}

/// The partial derivatives at fixed yarn state of the equilibrium `eq` of `tile` under
/// `model` with respect to `parameter` (per SI unit of the parameter): of the energy gradient
/// and of the gathered stress ([`crate::periodic::stress_sensitivities`] turns them into total
/// derivatives). Exact for `k_s1`, `k_s2`, `k_b` (with the twist following it) and `k_c1`, in
/// which the energy is linear: the gradient and stress of the model with only that stiffness set to 1.
/// Central differences at fixed state (relative step 1e-6) for the onset `Ȳ_s` and the radius
/// `R₁`, in which it is not; the contact pairs are the equilibrium's throughout. Zero for the
/// geometric parameters: they act on the input geometry before the rest-shape estimation, so
/// a given rest tile does not depend on them.
pub fn parameter_partial(
    tile: &Tile,
    model: &YarnModel,
    eq: &Equilibrium,
    parameter: Parameter,
) -> Result<Partial, FitError> {
    let at = |m: &YarnModel| -> Result<(Vec<f64>, nalgebra::Matrix2<f64>), FitError> {
        let problem = equilibrium_problem(tile, m, eq)?;
        Ok(problem.gradient_and_stress(&eq.dofs)?)
    };
    let mut unit = *model;
    unit.stretch = match model.stretch {
        StretchLaw::Linear { .. } => StretchLaw::Linear { k: 0.0 },
        StretchLaw::TwoPhase { onset, .. } => StretchLaw::TwoPhase {
            k1: 0.0,
            k2: 0.0,
            onset,
        },
    };
    unit.bending = 0.0;
    unit.twist = 0.0;
    unit.contact[0].stiffness = 0.0;
    unit.contact[1].stiffness = 0.0;
    let linear = |unit: YarnModel| -> Result<Partial, FitError> {
        let (gradient, stress) = at(&unit)?;
        Ok(Partial { gradient, stress })
    };
    match parameter {
        Parameter::GeometryX | Parameter::GeometryY => Ok(Partial {
            gradient: vec![0.0; eq.dofs.len()],
            stress: nalgebra::Matrix2::zeros(),
        }),
        // The energy is linear in k_s1 and k_s2 jointly (Eq. 5), so each partial is the
        // model with only that stiffness, at 1.
        Parameter::StretchSoft | Parameter::StretchStiff => {
            parameter.set(&mut unit, 1.0);
            linear(unit)
        }
        Parameter::Bending => {
            unit.bending = 1.0;
            unit.twist = if model.bending > 0.0 {
                model.twist / model.bending
            } else {
                0.0
            };
            linear(unit)
        }
        Parameter::ContactStiffness => {
            unit.contact[0].stiffness = 1.0;
            linear(unit)
        }
        Parameter::Onset | Parameter::ContactRadius => {
            let value = parameter.get(model);
            let h = 1e-6
                * value.abs().max(if parameter == Parameter::Onset {
                    0.01
                } else {
                    model.contact[0].radius
                });
            let shifted = |delta: f64| {
                let mut m = *model;
                parameter.set(&mut m, value + delta);
                at(&m)
            };
            let (gp, sp) = shifted(h)?;
            let (gm, sm) = shifted(-h)?;
            Ok(Partial {
                gradient: gp
                    .iter()
                    .zip(&gm)
                    .map(|(a, b)| (a - b) / (2.0 * h))
                    .collect(),
                stress: (sp - sm) / (2.0 * h),
            })
        }
    }
}

/// The input geometry `tile` stretched by `stretch = [a_x, a_y]` ([`Parameter::GeometryX`],
/// [`Parameter::GeometryY`]): positions and period `(x, y) → (a_x x, a_y y)`, reference frames
/// transported onto the stretched edges ([`crate::patterns::rebase_stretched`]), and the rest
/// shape reset to the stretched geometry, as a procedural tile's is its own geometry. The tile
/// itself at `[1, 1]`.
pub fn stretched_geometry(tile: &Tile, stretch: [f64; 2]) -> Result<Tile, FitError> {
    if stretch == [1.0, 1.0] {
        return Ok(tile.clone());
    }
    let zero = vec![0.0; 4 * tile.n_vertices()];
    let mut out = crate::patterns::rebase_stretched(tile, stretch, &zero)?;
    crate::patterns::reset_rest_shape(&mut out, None)?;
    Ok(out)
}

/// The base radius `R_est` of seed 002 §7.3.2: the smallest contact radius at which every
/// yarn segment of the tile's geometry touches another (centre-line distance `< 2R` to an
/// edge of another yarn or further along its own than `model.min_arc_separation`), i.e. half
/// the largest nearest-neighbour distance over the edges.
pub fn estimated_radius(tile: &Tile, model: &YarnModel) -> Result<f64, FitError> {
    let n = tile.n_vertices();
    let zero = vec![0.0; 4 * n];
    // Candidate pairs within a generous cutoff: half the larger period side.
    let reach = 0.5 * tile.period[0].max(tile.period[1]);
    let mut wide = *model;
    wide.contact[0].radius = 0.5 * reach;
    wide.contact[1].radius = 0.0;
    let pairs = PeriodicTile::find_pairs(tile, &wide, &Coarse::identity(), &zero, 1.0)?;
    let pos = |v: usize, shift: [i32; 2]| tile.positions[v] + tile.period_offset(shift);
    let mut nearest = vec![f64::INFINITY; tile.edges.len()];
    for p in &pairs {
        let (ea, eb) = (tile.edges[p.a], tile.edges[p.b]);
        let [i, j] = p.image;
        let d = closest_points(
            &pos(ea.v0, [0, 0]),
            &pos(ea.v1, ea.shift),
            &pos(eb.v0, p.image),
            &pos(eb.v1, [eb.shift[0] + i, eb.shift[1] + j]),
        )
        .2;
        nearest[p.a] = nearest[p.a].min(d);
        nearest[p.b] = nearest[p.b].min(d);
    }
    let worst = nearest.iter().copied().fold(0.0, f64::max);
    if !worst.is_finite() {
        return Err(FitError::Invalid(format!(
            "an edge of the tile has no other yarn within {reach:e} m: no base radius"
        )));
    }
    Ok(0.5 * worst)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalization_round_trips_and_respects_log_scale() {
        let base = YarnModel::default_for_radius(1e-3);
        let space = ParameterSpace::paper(&base, 1e-3).unwrap();
        assert_eq!(space.dim(), 5);
        let x = [0.1, 0.5, 0.25, 0.75, 0.9];
        let m = space.model(&x);
        let back = space.normalized(&m);
        for (a, b) in x.iter().zip(&back) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        // Log scale: the midpoint is the geometric mean.
        let k = Parameter::StretchSoft.get(&space.model(&[0.5, 0.0, 0.0, 0.0, 0.0]));
        assert!((k - (0.2f64 * 200.0).sqrt()).abs() < 1e-9 * k);
        // The twist keeps its ratio to the bending stiffness.
        assert!((m.twist / m.bending - base.twist / base.bending).abs() < 1e-12);
        assert_eq!(m.contact[1].radius, 0.25e-3);
    }

    #[test]
    fn bad_bounds_are_rejected_with_the_parameter_named() {
        let base = YarnModel::default_for_radius(1e-3);
        let bad = |free| ParameterSpace::new(base, free).unwrap_err().to_string();
        let b = |parameter, min, max| Bound {
            parameter,
            min,
            max,
        };
        assert!(bad(vec![b(Parameter::Bending, 0.0, 1.0)]).contains("bending"));
        assert!(bad(vec![b(Parameter::Onset, 0.2, 0.1)]).contains("onset"));
        let twice = vec![
            b(Parameter::ContactRadius, 1e-4, 1e-3),
            b(Parameter::ContactRadius, 1e-4, 1e-3),
        ];
        assert!(bad(twice).contains("twice"));
        assert!(bad(vec![]).contains("no parameter"));
        let flat = bad(vec![b(Parameter::GeometryY, 0.0, 1.2)]);
        assert!(
            flat.contains("geometry_y") && flat.contains("positive"),
            "{flat}"
        );
    }

    #[test]
    fn the_geometry_stretch_scales_positions_period_and_rest_lengths() {
        let pattern = crate::patterns::Pattern::Stockinette;
        let tile = pattern.generate(&pattern.default_params(1e-3)).unwrap();
        let base = YarnModel::default_for_radius(1e-3);
        let b = |parameter, min, max| Bound {
            parameter,
            min,
            max,
        };
        let space = ParameterSpace::new(
            base,
            vec![
                b(Parameter::Bending, 1e-9, 1e-7),
                b(Parameter::GeometryY, 0.8, 1.3),
            ],
        )
        .unwrap();
        // Not free: 1; free: its denormalized value (linear scale); the model is untouched.
        let stretch = space.geometry_stretch(&[0.5, 0.4]);
        assert_eq!(stretch[0], 1.0);
        assert!((stretch[1] - 1.0).abs() < 1e-12);
        assert!((space.geometry_stretch(&[0.5, 1.0])[1] - 1.3).abs() < 1e-12);
        assert_eq!(
            space.model(&[0.5, 0.0]).stretch,
            space.model(&[0.5, 1.0]).stretch
        );
        assert_eq!(stretched_geometry(&tile, [1.0, 1.0]).unwrap(), tile);

        let [ax, ay] = [1.2, 0.9];
        let out = stretched_geometry(&tile, [ax, ay]).unwrap();
        assert_eq!(out.period, [ax * tile.period[0], ay * tile.period[1]]);
        for (p, q) in tile.positions.iter().zip(&out.positions) {
            assert!((q - nalgebra::Vector3::new(ax * p.x, ay * p.y, p.z)).norm() < 1e-15);
        }
        // The rest shape is the stretched geometry's own: rest lengths are its edge lengths,
        // which changed.
        let mut changed = 0;
        for e in 0..out.edges.len() {
            let l = out.edge_vector(e).norm();
            assert!((out.rest_lengths[e] - l).abs() < 1e-12 * l);
            changed += usize::from((l - tile.rest_lengths[e]).abs() > 1e-3 * l);
        }
        assert!(
            changed > out.edges.len() / 2,
            "{changed} edges changed length"
        );
    }
}
