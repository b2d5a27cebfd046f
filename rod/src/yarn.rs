//! The one yarn description of the workbench: the mechanical properties a yarn has whatever
//! method simulates it, from which `sim-persistent` (`YarnParams::from_material`) and
//! `sim-periodic` (`YarnModel::from_material`) both build their models, so that a
//! cross-method comparison runs the *same* yarn through every method.
//!
//! | property | `sim-persistent` (seed 000) | `sim-periodic` (seed 002) |
//! |---|---|---|
//! | radius `R` | yarn radius: contact distance `2R` of the loop contact, crimp offset, layout | contact radius of the soft barrier phase `R₁ = R` (the stiff core `R₂ = R/4`, §6.3) |
//! | stretch law | sliding-segment stretch with this law; `Y = k/(πR²)` from the small-strain stiffness sets the defaults scaled by `k_s` | the segment stretch law (Eq. 5) |
//! | bending `k_b` | `B = k_b/(πR²)` of Eq. 1 (angle bending with jamming) | `k_b` of Eq. 6 (material-frame bending) |
//! | twist `k_t` | **no counterpart**: the persistent yarns carry no material frame (Eq. 1 bends by the turning angle only) | `k_t` of the twist energy |
//! | friction `μ` | Coulomb bound `μλ` of the sliding springs (Eq. 5) | **no counterpart**: the tile is a frictionless quasi-static equilibrium (yarns slide freely along each other) |
//! | linear density `ρ` | node masses | **no counterpart**: quasi-static, no inertia |
//!
//! What has no counterpart in the other direction, and why:
//!
//! - **Contacts.** Seed 000 keeps every yarn–yarn contact of a stitch *persistent*: a contact
//!   node shared by the two yarns, with stitch-length (Eq. 6), wrapping (Eq. 2) and, for
//!   weaves, crossing-shear energies, and a loop contact `k_c/3 (2R − d)³` between adjacent
//!   loops. Seed 002 resolves contact with a two-phase barrier (Eq. 7) between every pair of
//!   edges within the cutoff. Only the radius carries over: the persistent energies model the
//!   stitch as a joint, the barrier models the yarn cross-section's compliance, and their
//!   stiffnesses measure different things (each method keeps its own default).
//! - **Rest shape.** A persistent swatch starts from a procedural layout with the rest
//!   lengths of its segments; a periodic tile from its own (procedural or scanned) geometry.
//!   The two describe the same stitch, not the same curve.

use crate::stretch::StretchLaw;

/// The mechanics of a yarn, independent of the method (see the module documentation for how
/// each method uses every field). SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YarnMaterial {
    /// Yarn radius R (m).
    pub radius: f64,
    /// Stretch law (N): linear, or bi-phasic as seed 002 Eq. 5.
    pub stretch: StretchLaw,
    /// Bending stiffness `k_b` (N·m²).
    pub bending: f64,
    /// Twist stiffness `k_t` (N·m²).
    pub twist: f64,
    /// Yarn–yarn friction coefficient μ (unitless).
    pub friction: f64,
    /// Mass per unit length ρ (kg/m).
    pub linear_density: f64,
}

impl YarnMaterial {
    /// The stiffness of the stretch law at small positive strain (N): `k` of the linear law,
    /// `k₁` of the bi-phasic one (the regime a yarn at rest starts in), and `k₂` of a
    /// bi-phasic law whose onset is 0, which has no soft regime: it is the linear law with
    /// `k₂`, and maps to the same persistent yarn.
    ///
    /// The yarn fit's box has the onset's lower bound at 0 (`sim_periodic::fit`), and a fit
    /// that ends there leaves `k₁` anywhere in its box, with no effect on its curves. Mapped
    /// from `k₁` = 0.2 N instead (the `closed-loop` stockinette's fit with two swarms, 100×
    /// below the known yarn's 20 N), the persistent swatch took its stitch-length, friction
    /// and loop-contact stiffnesses 100× softer than with `k₂` and its weft stretch failed at
    /// s = 0.044 (Newton, 200 iterations, after 4 halvings); with them from the known 20 N it
    /// ran to the end (a throw-away probe).
    pub fn small_strain_stiffness(&self) -> f64 {
        match self.stretch {
            StretchLaw::Linear { k } => k,
            StretchLaw::TwoPhase { k1, onset, .. } if onset > 0.0 => k1,
            StretchLaw::TwoPhase { k2, .. } => k2,
        }
    }

    /// Checks that every property is finite and in range; the error names the property.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("radius", self.radius),
            ("linear_density", self.linear_density),
            ("stretch stiffness", self.small_strain_stiffness()),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("yarn {name} must be finite and > 0, got {v}"));
            }
        }
        let non_negative = [
            ("bending", self.bending),
            ("twist", self.twist),
            ("friction", self.friction),
        ];
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("yarn {name} must be finite and ≥ 0, got {v}"));
            }
        }
        if let StretchLaw::TwoPhase { k2, onset, .. } = self.stretch
            && !(k2.is_finite() && k2 > 0.0 && onset.is_finite() && onset >= 0.0)
        {
            return Err(format!(
                "yarn bi-phasic stretch needs k2 > 0 and onset ≥ 0, got k2 = {k2}, onset = {onset}"
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn yarn() -> YarnMaterial {
        YarnMaterial {
            radius: 1e-3,
            stretch: StretchLaw::TwoPhase {
                k1: 20.0,
                k2: 200.0,
                onset: 0.03,
            },
            bending: 5e-6,
            twist: 4e-6,
            friction: 0.3,
            linear_density: 3e-3,
        }
    }

    #[test]
    fn small_strain_stiffness_and_validation() {
        assert_eq!(yarn().small_strain_stiffness(), 20.0);
        let linear = YarnMaterial {
            stretch: StretchLaw::Linear { k: 7.0 },
            ..yarn()
        };
        assert_eq!(linear.small_strain_stiffness(), 7.0);
        // Without a soft regime the law is linear with k2, whatever k1.
        let no_soft = YarnMaterial {
            stretch: StretchLaw::TwoPhase {
                k1: 0.2,
                k2: 200.0,
                onset: 0.0,
            },
            ..yarn()
        };
        assert_eq!(no_soft.small_strain_stiffness(), 200.0);
        assert!(yarn().validate().is_ok());
        for (bad, name) in [
            (
                YarnMaterial {
                    radius: 0.0,
                    ..yarn()
                },
                "radius",
            ),
            (
                YarnMaterial {
                    friction: -0.1,
                    ..yarn()
                },
                "friction",
            ),
            (
                YarnMaterial {
                    bending: f64::NAN,
                    ..yarn()
                },
                "bending",
            ),
            (
                YarnMaterial {
                    stretch: StretchLaw::TwoPhase {
                        k1: 20.0,
                        k2: 200.0,
                        onset: -0.1,
                    },
                    ..yarn()
                },
                "onset",
            ),
        ] {
            let e = bad.validate().unwrap_err();
            assert!(e.contains(name), "{e}");
        }
    }
}
