//! Yarn material parameters (seed 000 §4, Table 1).

use rod::bending::Jamming;
use rod::geometry::V3;
use rod::stretch::StretchLaw;
use rod::yarn::YarnMaterial;

/// Which solver gives λ from Eq. 3 ([`crate::forces::compression::CompressionSystem`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CompressionSolver {
    /// The paper's closed form, Eq. 4 (exact for two yarns, which is every node of the
    /// current knit and weave topologies).
    #[default]
    ClosedForm,
    /// The exact non-negative least-squares minimizer of `½ fᵀf`.
    Nnls,
}

/// Settings of the compression estimate at contact nodes (seed 000 §4.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompressionSettings {
    /// Eq. 4 or exact NNLS. Default: Eq. 4 (the paper's).
    pub solver: CompressionSolver,
    /// Whether the stretch forces of Eq. 3 are evaluated with each yarn's node offset by
    /// one yarn radius along the contact normal (the paper's crimp offset, §4.3: "we offset
    /// nodes along the contact normal"). Default `true`.
    pub crimp_offset: bool,
}

impl Default for CompressionSettings {
    fn default() -> Self {
        Self {
            solver: CompressionSolver::ClosedForm,
            crimp_offset: true,
        }
    }
}

/// Default wrapping bias of [`WrappingRest::Layout`] (rad).
pub const DEFAULT_WRAP_BIAS: f64 = 0.1;

/// Where the rest angle ψ₀ of each stitch-wrapping pair (seed 000 Eq. 2) comes from.
///
/// Seed 000 lays its garments out from *stitch maps*, charts of a fabric relaxed to rest
/// (§4.1), and sets ψ₀ = π/2 "for a visually realistic wrapping effect" (§4.2); the
/// imbalance between the layout's wrapping and ψ₀ is what curls stockinette edges ("the
/// natural tendency to unwrap", §4.2, Figs. 5 and 7). Our layouts are built from the chart
/// alone and start unwrapped (ψ ≈ 0 at every pair: a flat layout cannot be wrapped
/// uniformly, see [`crate::forces::wrapping`]); a fixed quarter turn is then out of reach
/// of a flat sheet, which rolls a free stockinette into a rod of a few yarn diameters.
/// [`WrappingRest::Layout`] takes the layout, the geometry the fabric is knitted into, as
/// the wrapping rest state, and keeps the imbalance that curls the edges as a small bias
/// `β`: every pair's rest angle is its layout angle turned by `β` further in its wrapping
/// sense.
///
/// **The sense of the bias.** The edge curl of the paper, stockinette side edges to the back
/// and cast-on and bind-off to the front (as real stockinette curls), comes from a bias in
/// the wrapping sense (`β > 0`, the sense of the paper's ψ₀ = ±π/2 from an unwrapped
/// layout); the opposite sense rolls the edges the wrong way (sides to the front). Its size
/// sets the tightness of the roll: small enough that the interior of a free swatch stays
/// flat, large enough that the edges visibly curl (the `knit-fidelity` tests measure both).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WrappingRest {
    /// `ψ₀ = ψ_layout + σχ β`, with `ψ_layout` the pair's angle in the layout, `σχ` the
    /// pair's wrapping sense ([`crate::forces::wrapping::rest_angle_sign`]: the sign of a
    /// wrapped pair's ψ) and `β` = `wrap` (rad, ≥ 0).
    Layout {
        /// The wrapping bias β (rad). Default [`DEFAULT_WRAP_BIAS`].
        wrap: f64,
    },
    /// The paper's reading: `ψ₀ = σχ ψ̄` for every pair, `ψ̄` = `angle` (rad, π/2 in the
    /// paper), ramped in from the layout's angles
    /// ([`crate::integrator::StepSettings::wrapping_ramp_time`]).
    Fixed {
        /// The rest angle's magnitude ψ̄ (rad, in `[0, π)`).
        angle: f64,
    },
}

impl Default for WrappingRest {
    /// The layout's angles with the default bias, `Layout { wrap: DEFAULT_WRAP_BIAS }`: the
    /// rest state a free fabric can reach (the paper's fixed quarter turn rolls a free
    /// stockinette into a rod from our unwrapped layouts; [`WrappingRest::paper`] keeps it).
    fn default() -> Self {
        Self::Layout {
            wrap: DEFAULT_WRAP_BIAS,
        }
    }
}

impl WrappingRest {
    /// The paper's fixed quarter turn (§4.2).
    pub fn paper() -> Self {
        Self::Fixed {
            angle: std::f64::consts::FRAC_PI_2,
        }
    }

    /// The rest angle of a pair of wrapping sense `sign` (±1) whose angle in the layout is
    /// `layout_angle` (rad).
    pub fn rest_angle(&self, sign: f64, layout_angle: f64) -> f64 {
        match *self {
            Self::Layout { wrap } => layout_angle + sign * wrap,
            Self::Fixed { angle } => sign * angle,
        }
    }

    /// Checks the angle is finite and in range.
    pub fn validate(&self) -> Result<(), String> {
        let (name, v) = match *self {
            Self::Layout { wrap } => ("wrapping bias", wrap),
            Self::Fixed { angle } => ("wrapping rest angle", angle),
        };
        if !(v.is_finite() && (0.0..std::f64::consts::PI).contains(&v)) {
            return Err(format!("the {name} must be in [0, π) rad, got {v}"));
        }
        Ok(())
    }
}

/// Mechanical parameters of a yarn (SI units). Quantities the paper does not give are marked
/// as such, with the reason for the default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YarnParams {
    /// Yarn radius R (m). Table 1: 0.25–1.5 mm.
    pub radius: f64,
    /// Linear density ρ (kg/m). Not in the paper; default `1000 kg/m³ · π R²`.
    pub linear_density: f64,
    /// Elastic modulus Y (Pa); stretch stiffness `k_s = Y π R²` (N). Table 1: 1e7 Pa.
    pub young_modulus: f64,
    /// The stiff regime of a bi-phasic stretch law (seed 002 Eq. 5), `(k₂ (N), onset ε̄)`:
    /// with `Some`, the yarn segments follow `TwoPhase { k₁ = k_s, k₂, ε̄ }` (soft up to the
    /// onset, stiff beyond it and in compression); `None` (default, seed 000) the linear law.
    /// The other stiffnesses scaled by `k_s` keep using `k_s`.
    pub stiffening: Option<(f64, f64)>,
    /// Bending modulus B of Table 1 (1e-3, 3e-4); seed 000 §4.1 sets `k_b = B π R²`. The
    /// paper labels B in Pa, which would make `k_b` a force; we read it so that `k_b` is in
    /// N·m², as Eq. 1 (`V = k_b θ²/Δu`, in J) requires.
    pub bending_modulus: f64,
    /// Bending jamming (§4.1): ×1000 stiffening past θ = π/2.
    pub jamming: Jamming,
    /// Stitch-contact length stiffness `k_l` of Eq. 6 (N). Not in the paper; default `k_s`,
    /// so the contact length is as stiff as the yarn itself.
    pub stitch_length_stiffness: f64,
    /// Stick stiffness `k_f` of the friction springs of Eq. 5 (N/m). Not in the paper;
    /// default `k_s / R`, the axial stiffness of a yarn piece one radius long.
    pub friction_stiffness: f64,
    /// Friction coefficient μ of Eq. 5 (unitless): a sliding coordinate slips when its
    /// spring force exceeds `μ λ`, λ the compression of its contacts (Eqs. 3–4,
    /// [`crate::forces::compression`]). Table 1: 0.3 for all three garments (the default).
    pub friction_coefficient: f64,
    /// A constant slip force `F_max` (N) instead of `μ λ`: `None` (default) uses the
    /// compression estimate, `Some(F)` the behaviour of the first slice of the simulator
    /// (every free sliding coordinate slips at `F`, whatever the compression).
    pub friction_max_force: Option<f64>,
    /// How the compression λ of Eqs. 3–4 is estimated for the Coulomb bound `μ λ`.
    pub compression: CompressionSettings,
    /// Stitch-wrapping stiffness `k_w` of Eq. 2 (N). Table 1: 1e-2 for all three garments,
    /// labelled Pa; Eq. 2 (`V = ½ k_w L (ψ − ψ₀)²` with `L` in m) needs N for `V` in J, so
    /// the Table 1 number is read as N (no `π R²` factor: the paper gives none for `k_w`).
    pub wrapping_stiffness: f64,
    /// Where the stitch-wrapping rest angles ψ₀ of Eq. 2 come from. Default: the layout's
    /// angles with the bias [`DEFAULT_WRAP_BIAS`] ([`WrappingRest::default`]).
    pub wrapping_rest: WrappingRest,
    /// Stiffness `k_c` of the contact between adjacent loops
    /// ([`crate::forces::loop_contact`], `V = k_c/3 (2R − d)³`, N/m²). Not in the paper;
    /// default `0.1 k_s/R²`: a penetration of 5 % of the contact distance 2R (0.1 R) then
    /// pushes back with `1e-3 k_s` (18 mN for the Table 1 sweater yarn), ten times the
    /// typical yarn forces of a relaxed swatch, while the onset stays soft for Newton.
    pub loop_contact_stiffness: f64,
    /// Gravity acceleration (m/s²). Default `(0, −9.81, 0)`: the fabric's y axis (wale
    /// direction of knits) points up.
    pub gravity: V3,
}

impl YarnParams {
    /// Defaults for yarn radius `r` (m), modulus `Y` (Pa) and bending modulus `B` (Table 1).
    pub fn new(radius: f64, young_modulus: f64, bending_modulus: f64) -> Self {
        let area = std::f64::consts::PI * radius * radius;
        Self {
            radius,
            linear_density: 1000.0 * area,
            young_modulus,
            stiffening: None,
            bending_modulus,
            jamming: Jamming::default(),
            stitch_length_stiffness: young_modulus * area,
            friction_stiffness: young_modulus * area / radius,
            friction_coefficient: 0.3,
            friction_max_force: None,
            compression: CompressionSettings::default(),
            wrapping_stiffness: 1e-2,
            wrapping_rest: WrappingRest::default(),
            loop_contact_stiffness: 0.1 * young_modulus * area / (radius * radius),
            gravity: V3::new(0.0, -9.81, 0.0),
        }
    }

    /// Table 1, sweater (Fig. 1): R = 0.75 mm, Y = 1e7 Pa, B = 1e-3 (loop width 3 mm).
    pub fn sweater() -> Self {
        Self::new(0.75e-3, 1e7, 1e-3)
    }

    /// Table 1, sleeveless shirt (Fig. 10): R = 0.25 mm, Y = 1e7 Pa, B = 3e-4 (loop width 1 mm).
    pub fn shirt() -> Self {
        Self::new(0.25e-3, 1e7, 3e-4)
    }

    /// Table 1, sleeveless pullover (Fig. 7): R = 1.5 mm, Y = 1e7 Pa, B = 3e-4 (loop width 6 mm).
    pub fn pullover() -> Self {
        Self::new(1.5e-3, 1e7, 3e-4)
    }

    /// Stretch stiffness `k_s = Y π R²` (N).
    pub fn stretch_stiffness(&self) -> f64 {
        self.young_modulus * std::f64::consts::PI * self.radius * self.radius
    }

    /// The stretch law of the yarn segments: linear with `k_s`, or bi-phasic with
    /// [`YarnParams::stiffening`].
    pub fn stretch_law(&self) -> StretchLaw {
        let k = self.stretch_stiffness();
        match self.stiffening {
            None => StretchLaw::Linear { k },
            Some((k2, onset)) => StretchLaw::TwoPhase { k1: k, k2, onset },
        }
    }

    /// The parameters of the shared yarn description (`rod::yarn`): radius, linear density,
    /// friction coefficient; `Y = k/(πR²)` from the small-strain stretch stiffness with the
    /// bi-phasic stiff regime as [`YarnParams::stiffening`]; `B = k_b/(πR²)` (Eq. 1 with
    /// seed 000's `k_b = B π R²`). The twist stiffness has no counterpart (the persistent yarns
    /// carry no material frame); every other parameter keeps its default
    /// ([`YarnParams::new`]), gravity included.
    pub fn from_material(yarn: &YarnMaterial) -> Result<Self, String> {
        yarn.validate()?;
        let area = std::f64::consts::PI * yarn.radius * yarn.radius;
        let mut params = Self::new(
            yarn.radius,
            yarn.small_strain_stiffness() / area,
            yarn.bending / area,
        );
        params.linear_density = yarn.linear_density;
        params.friction_coefficient = yarn.friction;
        if let StretchLaw::TwoPhase { k2, onset, .. } = yarn.stretch {
            params.stiffening = Some((k2, onset));
        }
        params.validate()?;
        Ok(params)
    }

    /// Bending stiffness `k_b = B π R²` (N·m², seed 000 §4.1).
    pub fn bending_stiffness(&self) -> f64 {
        self.bending_modulus * std::f64::consts::PI * self.radius * self.radius
    }

    /// Checks that every parameter is finite and in range.
    pub fn validate(&self) -> Result<(), String> {
        let pos = [
            ("radius", self.radius),
            ("linear_density", self.linear_density),
            ("young_modulus", self.young_modulus),
        ];
        for (name, v) in pos {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} must be finite and > 0, got {v}"));
            }
        }
        let nonneg = [
            ("bending_modulus", self.bending_modulus),
            ("stitch_length_stiffness", self.stitch_length_stiffness),
            ("friction_stiffness", self.friction_stiffness),
            ("friction_coefficient", self.friction_coefficient),
            ("friction_max_force", self.friction_max_force.unwrap_or(0.0)),
            ("wrapping_stiffness", self.wrapping_stiffness),
            ("loop_contact_stiffness", self.loop_contact_stiffness),
        ];
        for (name, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{name} must be finite and ≥ 0, got {v}"));
            }
        }
        if let Some((k2, onset)) = self.stiffening
            && !(k2.is_finite() && k2 > 0.0 && onset.is_finite() && onset >= 0.0)
        {
            return Err(format!(
                "stiffening needs k2 > 0 and onset ≥ 0, got k2 = {k2}, onset = {onset}"
            ));
        }
        self.wrapping_rest.validate()?;
        if !self.gravity.iter().all(|g| g.is_finite()) {
            return Err("gravity must be finite".into());
        }
        Ok(())
    }
}
