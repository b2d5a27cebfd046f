//! The in-plane fit of seed 002, Eq. 2, by simulation in the loop:
//!
//! ```text
//! k_inplane = argmin Σ_i w_s (f_s(k, s_i) − f_s,i)² + w_c (c(k, s_i) − c_i)²
//! ```
//!
//! over `k = {kxx, kxy, kyy, kss, kn1, kn2}` (plus the rates `{bx, by, cx, cy}` for
//! [`Model::Stiffening`]) with `6` targets per available direction, evenly
//! spread over the measured stretch range (`s_i = s_max i/6`, `i = 1 … 6`, measured values
//! interpolated from the binned curve). The weights normalize each residual by the average
//! measured force or compression **of its direction** (`w_s = 1/mean(f)²`, `w_c = 1/mean(c)²`),
//! so every direction counts equally whatever its stiffness.
//!
//! **Error metrics.** [`FitResult`] reports two: the paper's (§5.1, Fig. 13), the mean absolute
//! error of a direction **relative to the average measured datum of that direction**,
//! `Σ_i |f_sim,i − f_i| / Σ_i |f_i|` (likewise for compression), averaged over the directions
//! for the fabric; and the mean of per-point relative errors `|f_sim,i − f_i|/|f_i|`, which is
//! dominated by the near-zero data at small stretch (hundreds of percent for compression) and
//! is not comparable with the paper.
//!
//! **Derivatives.** Each residual's gradient comes from the adjoint sensitivities of the
//! equilibrium ([`StretchTest::sensitivities`]: one sparse LU of the exact Hessian per target,
//! two back-substitutions), not from finite differences of the black box.
//!
//! **Optimizer.** [`solver::bounded_lm`]: Levenberg–Marquardt in scaled parameters `p_k / scale_k` with Marquardt's
//! diagonal damping, bounds by projection onto the box `[lower, upper]`, plus
//! `|kxy| ≤ 0.95 √(kxx kyy)` (positive definite `K`). A trial step whose equilibria fail to
//! converge is rejected like a step that increases the cost (λ grows); only a failure at the
//! initial guess is an error.

use rayon::prelude::*;
use std::time::Instant;
use yarn_pattern::direction::Direction;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use solver::{
    Bracket, LmBounds, LmError, LmEval, LmSettings, RootEval, RootSettings, bounded_lm, find_root,
};

use crate::ShellError;
use crate::curves::uniaxial_sensitivity;
use crate::material::{InPlaneParams, Material, Model};
use crate::measurements::Measurement;
use crate::swatch::{StretchTest, SwatchConfig};
use std::collections::BTreeMap;

/// One fit target: a stretch and the measured force and compression there.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Target {
    /// Direction of the test.
    pub direction: Direction,
    /// Stretch `s_i`.
    pub s: f64,
    /// Measured force `f_s,i` (N).
    pub force: f64,
    /// Measured compression `c_i`.
    pub compression: f64,
}

/// `n` targets per measurement at `s_max i/n`, `i = 1 … n`.
pub fn targets(measurements: &[Measurement], n: usize) -> Vec<Target> {
    let mut out = Vec::new();
    for m in measurements {
        for i in 1..=n {
            let p = m.interpolate(m.s_max() * i as f64 / n as f64);
            out.push(Target {
                direction: m.direction,
                s: p.s,
                force: p.force,
                compression: p.compression,
            });
        }
    }
    out
}

/// How the residuals of Eq. 2 are weighted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Weighting {
    /// The paper's: normalize by the mean measured force / compression of the direction
    /// (the compression's at least [`COMPRESSION_FLOOR`]).
    DirectionMean,
    /// Relative residuals `(f_sim − f_i)/f_i`, `(c_sim − c_i)/c_i`: minimizes (the squares
    /// of) exactly the relative errors that are reported.
    Relative,
}

/// Smallest mean compression a direction is normalized by in [`Weighting::DirectionMean`]
/// (unitless): a fabric that does not contract (a straight-yarn weave, measured or
/// simulated) would otherwise weigh its compression residuals by 1/0 and the fit would ignore
/// the forces. 1 % is below what the shared measurements resolve; the yarn fit floors its
/// compression normalization the same way.
pub const COMPRESSION_FLOOR: f64 = 0.01;

/// Largest stiffening rate (`bx`, `by`, `cx`, `cy`) the fit may use (per unit Green strain): `e^{bE}` then
/// spans `e^{10}` over a Green strain of 0.2.
pub const MAX_RATE: f64 = 50.0;

/// Lower bound of `kn2` (N/m) for [`Model::Stiffening`]: keeps its `log² J` inversion barrier
/// present whatever the data (the paper's model may fit `kn2 = 0`).
pub const STIFFENING_MIN_KN2: f64 = 0.1;

/// The swatch of `direction`: its own in `direction_swatches`, else `common`.
fn swatch_of<'a>(
    common: &'a SwatchConfig,
    direction_swatches: &'a BTreeMap<Direction, SwatchConfig>,
    direction: Direction,
) -> &'a SwatchConfig {
    direction_swatches.get(&direction).unwrap_or(common)
}

impl FitConfig {
    /// The swatch of `direction`'s tests: its own ([`FitConfig::direction_swatches`]) or the
    /// common one.
    pub fn swatch_for(&self, direction: Direction) -> &SwatchConfig {
        swatch_of(&self.swatch, &self.direction_swatches, direction)
    }

    /// The default settings for `model` (bounds adapted to it).
    pub fn for_model(model: Model) -> Self {
        let mut cfg = Self {
            model,
            ..Self::default()
        };
        if model == Model::Stiffening {
            cfg.lower[5] = STIFFENING_MIN_KN2;
        }
        cfg
    }
}

/// The virtual test that maps material parameters to the force and compression of a target.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum VirtualTest {
    /// The paper's (§4.3): the clamped swatch of [`SwatchConfig`] simulated to equilibrium;
    /// `s` is the clamp stretch, `c` the contraction of the swatch's mid-length width.
    #[default]
    Swatch,
    /// A homogeneous uniaxial-stress state (Eq. 3 kinematics, zero orthogonal stress):
    /// `c` and `f_s = w̄ σ_s` of the material point itself ([`uniaxial_sensitivity`]). The
    /// model for strains measured locally on the specimen (tracked stitches away from the
    /// clamps), where the clamps' restraint of the width does not reach; no FEM solve.
    Uniaxial,
}

impl VirtualTest {
    /// Both tests.
    pub const ALL: [VirtualTest; 2] = [VirtualTest::Swatch, VirtualTest::Uniaxial];

    /// Lower-case name (`swatch`, `uniaxial`).
    pub fn name(self) -> &'static str {
        match self {
            VirtualTest::Swatch => "swatch",
            VirtualTest::Uniaxial => "uniaxial",
        }
    }
}

/// Fit settings.
#[derive(Clone, Debug, PartialEq)]
pub struct FitConfig {
    /// Residual weighting. Default [`Weighting::DirectionMean`] (the paper's).
    pub weighting: Weighting,
    /// Parameters held at their initial value (e.g. `kss` when there is no bias test, which
    /// leaves it unidentifiable). Default none. Parameters the model does not use are always
    /// held.
    pub fixed: [bool; InPlaneParams::LEN],
    /// The virtual test. Default [`VirtualTest::Swatch`] (the paper's).
    pub test: VirtualTest,
    /// Swatch of the virtual tests (for [`VirtualTest::Uniaxial`] only its width, which
    /// turns stress into force).
    pub swatch: SwatchConfig,
    /// Swatches of single directions, in place of [`FitConfig::swatch`] for those: a fabric
    /// whose strips were cut to different sizes per direction (length along the pull, width
    /// across it). Default none.
    pub direction_swatches: BTreeMap<Direction, SwatchConfig>,
    /// Material model fitted. Default [`Model::Augmented`].
    pub model: Model,
    /// Lower bounds (order of [`InPlaneParams::to_array`]). Default
    /// `[1, −∞, 1, 0.1, 0, 0, 0, 0, 0, 0]`; [`Model::Stiffening`] raises the `kn2` bound to
    /// [`STIFFENING_MIN_KN2`] so that its `log² J` barrier is always present.
    pub lower: [f64; InPlaneParams::LEN],
    /// Upper bounds. Default `1e6` N/m for the stiffnesses, [`MAX_RATE`] for the rates.
    pub upper: [f64; InPlaneParams::LEN],
    /// Maximum LM iterations (accepted or rejected). Default 60.
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction. Default `1e-10`.
    pub cost_rtol: f64,
    /// Stop when the scaled step is smaller than this. Default `1e-9`.
    pub step_tol: f64,
}

impl Default for FitConfig {
    fn default() -> Self {
        Self {
            test: VirtualTest::Swatch,
            swatch: SwatchConfig::default(),
            direction_swatches: BTreeMap::new(),
            weighting: Weighting::DirectionMean,
            fixed: [false; InPlaneParams::LEN],
            model: Model::Augmented,
            lower: [
                1.0,
                f64::NEG_INFINITY,
                1.0,
                0.1,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
            ],
            upper: [
                1e6, 1e6, 1e6, 1e6, 1e6, 1e6, MAX_RATE, MAX_RATE, MAX_RATE, MAX_RATE,
            ],
            max_iterations: 60,
            cost_rtol: 1e-10,
            step_tol: 1e-9,
        }
    }
}

/// Per-direction fit quality (both metrics of the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DirectionError {
    /// Direction.
    pub direction: Direction,
    /// Paper metric: `Σ|f_sim − f_i| / Σ|f_i|` over the direction's points.
    pub force_error: f64,
    /// Paper metric: `Σ|c_sim − c_i| / Σ|c_i|` over the direction's points.
    pub compression_error: f64,
    /// Mean of `|f_sim − f_i| / |f_i|` over the direction's points.
    pub force_rel_error: f64,
    /// Mean of `|c_sim − c_i| / |c_i|` over the direction's points.
    pub compression_rel_error: f64,
}

/// Fit quality of simulated against measured points: per direction (in [`Direction::ALL`]
/// order, present directions only) and the fabric's overall paper metric (the mean over its
/// directions).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorReport {
    /// Per direction.
    pub directions: Vec<DirectionError>,
    /// Paper metric of force, mean over the directions.
    pub force_error: f64,
    /// Paper metric of compression, mean over the directions.
    pub compression_error: f64,
    /// Mean per-point relative force error over all points.
    pub force_rel_error: f64,
    /// Mean per-point relative compression error over all points.
    pub compression_rel_error: f64,
}

impl ErrorReport {
    /// Compares `simulated` with `measured` (pairwise; same directions and stretches).
    pub fn new(measured: &[Target], simulated: &[Target]) -> Self {
        let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-12);
        let pairs: Vec<(&Target, &Target)> = measured.iter().zip(simulated).collect();
        let summary = |sel: &[&(&Target, &Target)]| {
            let n = sel.len() as f64;
            let ratio = |get: fn(&Target) -> f64| {
                sel.iter()
                    .map(|(t, s)| (get(s) - get(t)).abs())
                    .sum::<f64>()
                    / sel
                        .iter()
                        .map(|(t, _)| get(t).abs())
                        .sum::<f64>()
                        .max(1e-300)
            };
            let mean_rel = |get: fn(&Target) -> f64| {
                sel.iter().map(|(t, s)| rel(get(s), get(t))).sum::<f64>() / n
            };
            (
                ratio(|t| t.force),
                ratio(|t| t.compression),
                mean_rel(|t| t.force),
                mean_rel(|t| t.compression),
            )
        };
        let mut directions = Vec::new();
        for d in Direction::ALL {
            let sel: Vec<&(&Target, &Target)> =
                pairs.iter().filter(|(t, _)| t.direction == d).collect();
            if sel.is_empty() {
                continue;
            }
            let (f, c, fr, cr) = summary(&sel);
            directions.push(DirectionError {
                direction: d,
                force_error: f,
                compression_error: c,
                force_rel_error: fr,
                compression_rel_error: cr,
            });
        }
        let all: Vec<&(&Target, &Target)> = pairs.iter().collect();
        let (_, _, force_rel_error, compression_rel_error) = summary(&all);
        let nd = directions.len().max(1) as f64;
        Self {
            force_error: directions.iter().map(|d| d.force_error).sum::<f64>() / nd,
            compression_error: directions.iter().map(|d| d.compression_error).sum::<f64>() / nd,
            directions,
            force_rel_error,
            compression_rel_error,
        }
    }
}

/// Result of [`fit`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitResult {
    /// Fitted parameters (N/m).
    pub params: InPlaneParams,
    /// Initial guess (N/m).
    pub initial: InPlaneParams,
    /// Final cost (weighted sum of squares, Eq. 2).
    pub cost: f64,
    /// Cost after every accepted step (first entry: the initial guess).
    pub cost_history: Vec<f64>,
    /// LM iterations (accepted and rejected).
    pub iterations: usize,
    /// Simulated force and compression at the targets with the fitted parameters.
    pub simulated: Vec<Target>,
    /// The targets.
    pub targets: Vec<Target>,
    /// Errors at the targets, in both metrics.
    pub errors: ErrorReport,
    /// The fitted model.
    pub model: Model,
    /// Wall time (s).
    pub seconds: f64,
    /// Why it stopped.
    pub termination: String,
}

/// Simulates all targets of one direction with warm starts; keeps one stretch test and the
/// equilibrium state at every target.
struct DirectionSim {
    test: StretchTest,
    /// Indices into the target list, increasing in `s`.
    idx: Vec<usize>,
    states: Vec<Option<Vec<f64>>>,
}

/// `(∂f_s/∂p, ∂c/∂p)` of one target.
type Jacobian = ([f64; InPlaneParams::LEN], [f64; InPlaneParams::LEN]);

/// One direction's simulated `(f_s, c)` and (if asked) Jacobian per target, in `idx` order,
/// and the equilibrium states.
type DirectionResult = (Vec<((f64, f64), Option<Jacobian>)>, Vec<Vec<f64>>);

impl DirectionSim {
    /// Simulates this direction's targets with `material`, each warm-started from its
    /// previous accepted equilibrium or, failing that, continued from the previous target (or
    /// from rest).
    fn simulate(
        &mut self,
        material: Material,
        targets: &[Target],
        with_jac: bool,
    ) -> Result<DirectionResult, ShellError> {
        self.test.set_material(material);
        let mut points = Vec::with_capacity(self.idx.len());
        let mut new_states: Vec<Vec<f64>> = Vec::with_capacity(self.idx.len());
        for (j, &ti) in self.idx.iter().enumerate() {
            let s = targets[ti].s;
            let mut point = None;
            if let Some(x) = &self.states[j] {
                self.test.set_state(s, x)?;
                point = self.test.solve_to(s).ok();
            }
            let point = match point {
                Some(p) => p,
                None => {
                    match new_states.last() {
                        Some(x) => self.test.set_state(targets[self.idx[j - 1]].s, x)?,
                        None => self.test.reset(),
                    }
                    self.test.solve_to(s)?
                }
            };
            let sensitivity = if with_jac {
                let sens = self.test.sensitivities()?;
                Some((sens.force, sens.compression))
            } else {
                None
            };
            points.push(((point.force, point.compression), sensitivity));
            new_states.push(self.test.positions().to_vec());
        }
        Ok((points, new_states))
    }
}

struct Evaluation {
    sim: Vec<(f64, f64)>,
    jac: Option<Vec<Jacobian>>,
    states: Vec<Vec<Option<Vec<f64>>>>,
}

/// The simulator that maps parameters to simulated targets (and their sensitivities).
pub struct Simulator {
    /// One stretch test per direction ([`VirtualTest::Swatch`]; empty for
    /// [`VirtualTest::Uniaxial`]).
    dirs: Vec<DirectionSim>,
    n_targets: usize,
    model: Model,
    test: VirtualTest,
    /// Swatch width `w̄` (m) per direction ([`Direction::ALL`] order).
    widths: [f64; 3],
}

impl Simulator {
    /// One `test` per direction present in `targets`, all on the swatch `cfg`.
    pub fn new(
        test: VirtualTest,
        cfg: &SwatchConfig,
        model: Model,
        targets: &[Target],
    ) -> Result<Self, ShellError> {
        Self::with_swatches(test, cfg, &BTreeMap::new(), model, targets)
    }

    /// [`Simulator::new`] with the swatches of single directions in `direction_swatches`
    /// ([`FitConfig::direction_swatches`]).
    pub fn with_swatches(
        test: VirtualTest,
        swatch: &SwatchConfig,
        direction_swatches: &BTreeMap<Direction, SwatchConfig>,
        model: Model,
        targets: &[Target],
    ) -> Result<Self, ShellError> {
        let swatch_for = |d: Direction| swatch_of(swatch, direction_swatches, d);
        let widths = Direction::ALL.map(|d| swatch_for(d).width);
        if let Some((d, w)) =
            (Direction::ALL.iter().zip(widths)).find(|(_, w)| !(*w > 0.0 && w.is_finite()))
        {
            let which = match direction_swatches.contains_key(d) {
                true => format!("the {} swatch", d.name()),
                false => "the common swatch".to_string(),
            };
            return Err(ShellError::InvalidInput(format!(
                "swatch width must be positive, got {w} ({which})"
            )));
        }
        let mut dirs = Vec::new();
        for d in Direction::ALL {
            if test == VirtualTest::Uniaxial {
                break;
            }
            let mut idx: Vec<usize> = (0..targets.len())
                .filter(|&i| targets[i].direction == d)
                .collect();
            if idx.is_empty() {
                continue;
            }
            idx.sort_by(|&a, &b| targets[a].s.total_cmp(&targets[b].s));
            let material = Material {
                params: InPlaneParams::example(),
                model,
            };
            dirs.push(DirectionSim {
                test: StretchTest::new(swatch_for(d), material, d.angle())?,
                states: vec![None; idx.len()],
                idx,
            });
        }
        Ok(Self {
            dirs,
            n_targets: targets.len(),
            model,
            test,
            widths,
        })
    }

    /// The swatch width of `direction`'s tests (m).
    fn width(&self, direction: Direction) -> f64 {
        let i = Direction::ALL.iter().position(|&d| d == direction);
        self.widths[i.expect("Direction::ALL holds every direction")]
    }

    /// [`VirtualTest::Uniaxial`]: every target from its own material point.
    fn evaluate_uniaxial(
        &self,
        p: &InPlaneParams,
        targets: &[Target],
        with_jac: bool,
    ) -> Result<Evaluation, ShellError> {
        let material = Material {
            params: *p,
            model: self.model,
        };
        let mut sim = Vec::with_capacity(targets.len());
        let mut jac = Vec::with_capacity(if with_jac { targets.len() } else { 0 });
        for t in targets {
            let u = uniaxial_sensitivity(&material, t.s, t.direction.angle())?;
            let w = self.width(t.direction);
            sim.push((w * u.point.sigma, u.point.c));
            if with_jac {
                jac.push((u.sigma.map(|d| w * d), u.compression));
            }
        }
        Ok(Evaluation {
            sim,
            jac: with_jac.then_some(jac),
            states: Vec::new(),
        })
    }

    fn evaluate(
        &mut self,
        p: &InPlaneParams,
        targets: &[Target],
        with_jac: bool,
    ) -> Result<Evaluation, ShellError> {
        if self.test == VirtualTest::Uniaxial {
            return self.evaluate_uniaxial(p, targets, with_jac);
        }
        let material = Material {
            params: *p,
            model: self.model,
        };
        // The directions are independent stretch tests: run them in parallel, merged in
        // direction order (the first direction's error wins, as when they ran in turn).
        let simulated: Vec<_> = self
            .dirs
            .par_iter_mut()
            .map(|d| d.simulate(material, targets, with_jac))
            .collect();
        let mut sim = vec![(0.0, 0.0); self.n_targets];
        let mut jac = with_jac
            .then(|| vec![([0.0; InPlaneParams::LEN], [0.0; InPlaneParams::LEN]); self.n_targets]);
        let mut states = Vec::with_capacity(simulated.len());
        for (d, result) in self.dirs.iter().zip(simulated) {
            let (points, new_states) = result?;
            for (&ti, (point, sensitivity)) in d.idx.iter().zip(points) {
                sim[ti] = point;
                if let (Some(jac), Some(sensitivity)) = (jac.as_mut(), sensitivity) {
                    jac[ti] = sensitivity;
                }
            }
            states.push(new_states.into_iter().map(Some).collect());
        }
        Ok(Evaluation { sim, jac, states })
    }

    /// Simulated `(f_s, c)` at every target for parameters `p` (warm-started from the last
    /// evaluation, whose states are then replaced).
    pub fn simulate(
        &mut self,
        p: &InPlaneParams,
        targets: &[Target],
    ) -> Result<Vec<(f64, f64)>, ShellError> {
        let e = self.evaluate(p, targets, false)?;
        self.commit(e.states);
        Ok(e.sim)
    }

    fn commit(&mut self, states: Vec<Vec<Option<Vec<f64>>>>) {
        for (d, s) in self.dirs.iter_mut().zip(states) {
            d.states = s;
        }
    }
}

/// Residual weights `(√w_s, √w_c)` per target (per-direction mean normalization).
fn weights(targets: &[Target], weighting: Weighting) -> Vec<(f64, f64)> {
    targets
        .iter()
        .map(|t| {
            if weighting == Weighting::Relative {
                return (
                    1.0 / t.force.abs().max(1e-12),
                    1.0 / t.compression.abs().max(1e-12),
                );
            }
            let same: Vec<&Target> = targets
                .iter()
                .filter(|u| u.direction == t.direction)
                .collect();
            let n = same.len() as f64;
            let mf = same.iter().map(|u| u.force.abs()).sum::<f64>() / n;
            let mc = same.iter().map(|u| u.compression.abs()).sum::<f64>() / n;
            (1.0 / mf.max(1e-12), 1.0 / mc.max(COMPRESSION_FLOOR))
        })
        .collect()
}

/// A starting point from the measured curves: `kxx`, `kyy` from the largest-stretch secant
/// of the weft / warp force (`σ ≈ k E (1+s)` with `σ = f/w̄`), `kss` from the bias if present,
/// small coupling and area terms. Missing directions borrow from the others.
pub fn initial_guess(measurements: &[Measurement], swatch_width: f64) -> InPlaneParams {
    guess(measurements, &|_| swatch_width)
}

/// [`initial_guess`] with a swatch width per direction.
fn guess(measurements: &[Measurement], swatch_width: &dyn Fn(Direction) -> f64) -> InPlaneParams {
    let secant = |d: Direction| {
        measurements.iter().find(|m| m.direction == d).map(|m| {
            let p = m.points.last().expect("non-empty");
            let e = 0.5 * ((1.0 + p.s).powi(2) - 1.0);
            (p.force / swatch_width(d) / (e * (1.0 + p.s))).max(1.0)
        })
    };
    let (kx, ky, kb) = (
        secant(Direction::Weft),
        secant(Direction::Warp),
        secant(Direction::Bias),
    );
    let any = kx.or(ky).or(kb).unwrap_or(100.0);
    let kxx = kx.unwrap_or(any);
    let kyy = ky.unwrap_or(any);
    let kss = kb.map_or(0.5 * kxx.min(kyy), |b| 0.5 * b);
    InPlaneParams {
        kxx,
        kxy: 0.1 * (kxx * kyy).sqrt(),
        kyy,
        kss,
        kn1: 0.1 * kxx.min(kyy),
        kn2: 0.1 * kxx.min(kyy),
        bx: 0.0,
        by: 0.0,
        cx: 0.0,
        cy: 0.0,
    }
}

/// [`initial_guess`] for `model`: for [`Model::Stiffening`] each measured normal direction's
/// rate `b` and small-strain stiffness `k` are estimated from two points of its force curve
/// (half and full range) under the uniaxial reading `f/(w̄(1+s)) ≈ k φ'(E; b)`, whose ratio
/// `(e^{bE₂} − 1)/(e^{bE₁} − 1)` increases with `b`; `b = 0` when the curve is not convex.
pub fn initial_guess_for(
    model: Model,
    measurements: &[Measurement],
    swatch_width: f64,
) -> InPlaneParams {
    guess_for(model, measurements, &|_| swatch_width)
}

/// [`initial_guess_for`] on the swatches of `cfg` ([`FitConfig::swatch_for`]).
pub fn initial_guess_for_config(
    model: Model,
    measurements: &[Measurement],
    cfg: &FitConfig,
) -> InPlaneParams {
    guess_for(model, measurements, &|d| cfg.swatch_for(d).width)
}

fn guess_for(
    model: Model,
    measurements: &[Measurement],
    swatch_width: &dyn Fn(Direction) -> f64,
) -> InPlaneParams {
    let mut p = guess(measurements, swatch_width);
    if model != Model::Stiffening {
        return p;
    }
    for (d, k, b) in [(Direction::Weft, 0, 6), (Direction::Warp, 2, 7)] {
        let Some(m) = measurements.iter().find(|m| m.direction == d) else {
            continue;
        };
        let stress = |s: f64| {
            let q = m.interpolate(s);
            (
                q.force / (swatch_width(d) * (1.0 + s)),
                0.5 * ((1.0 + s).powi(2) - 1.0),
            )
        };
        let ((t1, e1), (t2, e2)) = (stress(0.5 * m.s_max()), stress(m.s_max()));
        if !(t1 > 0.0 && t2 > 0.0 && e1 > 0.0) {
            continue;
        }
        let target = (t2 / t1).ln();
        // ln R(b) − ln R_measured, increasing in b; R(0) = E₂/E₁.
        let f = |b: f64| {
            let r = if b == 0.0 {
                e2 / e1
            } else {
                (b * e2).exp_m1() / (b * e1).exp_m1()
            };
            r.ln() - target
        };
        let (f_lo, f_hi) = (f(0.0), f(MAX_RATE));
        let rate = if f_lo >= 0.0 {
            0.0
        } else if f_hi <= 0.0 {
            MAX_RATE
        } else {
            let bracket = Bracket {
                lo: 0.0,
                hi: MAX_RATE,
                f_lo,
                f_hi,
            };
            let eval = |b: f64| Ok::<_, std::convert::Infallible>(RootEval::value(f(b)));
            find_root(bracket, None, &RootSettings::default(), eval).map_or(0.0, |r| r.x)
        };
        let phi1 = if rate == 0.0 {
            e2
        } else {
            (rate * e2).exp_m1() / rate
        };
        let mut a = p.to_array();
        a[k] = (t2 / phi1).max(1.0);
        a[b] = rate;
        p = InPlaneParams::from_array(a);
    }
    // Coupling from the measured lateral contraction: uniaxial StVK has
    // −E₂₂/E₁₁ = kxy/kyy in a weft pull and −E₁₁/E₂₂ = kxy/kxx in a warp pull (Green strains
    // at the largest stretch); average the estimates the data allow.
    let ratio = |d: Direction| {
        measurements
            .iter()
            .find(|m| m.direction == d)
            .and_then(|m| {
                let q = m.points.last()?;
                let along = 0.5 * ((1.0 + q.s).powi(2) - 1.0);
                let across = 0.5 * ((1.0 - q.compression).powi(2) - 1.0);
                (along > 0.0).then(|| (-across / along).max(0.0))
            })
    };
    let estimates: Vec<f64> = [
        ratio(Direction::Weft).map(|nu| nu * p.kyy),
        ratio(Direction::Warp).map(|nu| nu * p.kxx),
    ]
    .into_iter()
    .flatten()
    .collect();
    if !estimates.is_empty() {
        let kxy = estimates.iter().sum::<f64>() / estimates.len() as f64;
        p.kxy = kxy.min(0.9 * (p.kxx * p.kyy).sqrt());
    }
    p
}

fn project(p: &mut [f64; InPlaneParams::LEN], cfg: &FitConfig) {
    for k in 0..InPlaneParams::LEN {
        p[k] = p[k].clamp(cfg.lower[k], cfg.upper[k]);
    }
    let bound = 0.95 * (p[0] * p[2]).sqrt();
    p[1] = p[1].clamp(-bound, bound);
}

/// Progress callback: `(iteration, cost)` after each accepted LM step.
pub type Progress<'a> = solver::lm::LmProgress<'a>;

/// A [`solver::LmError`] as a [`ShellError`]: the initial evaluation's own error, or invalid
/// input.
pub(crate) fn lm_error(e: LmError<ShellError>) -> ShellError {
    match e {
        LmError::InitialEvaluation(e) => e,
        LmError::InvalidInput(detail) => ShellError::InvalidInput(detail),
    }
}

/// Fits the in-plane parameters to `targets` from `initial` (see the module docs).
pub fn fit(
    targets: &[Target],
    initial: InPlaneParams,
    cfg: &FitConfig,
    progress: Option<Progress<'_>>,
) -> Result<FitResult, ShellError> {
    let start = Instant::now();
    if targets.is_empty() {
        return Err(ShellError::InvalidInput("no fit targets".into()));
    }
    if let Some(t) = targets
        .iter()
        .find(|t| !(t.s.is_finite() && t.force.is_finite() && t.compression.is_finite()))
    {
        return Err(ShellError::InvalidInput(format!(
            "non-finite fit target {t:?}"
        )));
    }
    let sim = std::cell::RefCell::new(Simulator::with_swatches(
        cfg.test,
        &cfg.swatch,
        &cfg.direction_swatches,
        cfg.model,
        targets,
    )?);
    let w = weights(targets, cfg.weighting);
    let m = 2 * targets.len();
    let residuals = |e: &[(f64, f64)]| -> DVector<f64> {
        DVector::from_fn(m, |r, _| {
            let (t, (wf, wc)) = (&targets[r / 2], w[r / 2]);
            if r % 2 == 0 {
                wf * (e[r / 2].0 - t.force)
            } else {
                wc * (e[r / 2].1 - t.compression)
            }
        })
    };
    let mut p = initial.to_array();
    project(&mut p, cfg);
    let mut fixed = cfg.fixed;
    for (k, f) in fixed.iter_mut().enumerate() {
        *f |= !cfg.model.uses(k);
    }
    let scale: [f64; InPlaneParams::LEN] = std::array::from_fn(|k| {
        let v = p[k].abs();
        if InPlaneParams::RATES.contains(&k) {
            v.max(1.0)
        } else if v > 0.0 {
            v
        } else {
            (p[0] * p[2]).sqrt().max(1.0) * 0.1
        }
    });
    let mut eval = |q: &[f64; InPlaneParams::LEN]| -> Result<LmEval<Evaluation>, ShellError> {
        let e = sim
            .borrow_mut()
            .evaluate(&InPlaneParams::from_array(*q), targets, true)?;
        let r = residuals(&e.sim);
        let rows = e.jac.as_ref().expect("Jacobian requested");
        let j = DMatrix::from_fn(m, InPlaneParams::LEN, |row, k| {
            let (wf, wc) = w[row / 2];
            let (df, dc) = &rows[row / 2];
            if row % 2 == 0 { wf * df[k] } else { wc * dc[k] }
        });
        Ok((r, j, e))
    };
    let mut simulated_values = Vec::new();
    let mut commit = |mut e: Evaluation, _: &mut DMatrix<f64>| {
        sim.borrow_mut().commit(std::mem::take(&mut e.states));
        simulated_values = e.sim;
        Ok(())
    };
    let outcome = bounded_lm(
        p,
        &LmBounds {
            lower: cfg.lower,
            upper: cfg.upper,
            fixed,
            scale,
        },
        &LmSettings {
            max_iterations: cfg.max_iterations,
            cost_rtol: cfg.cost_rtol,
            step_tol: cfg.step_tol,
            residual_tol: 0.0,
        },
        &|q: &mut [f64; InPlaneParams::LEN]| project(q, cfg),
        &mut eval,
        &mut commit,
        progress,
    )
    .map_err(lm_error)?;
    let (p, cost, history, iterations, termination) = (
        outcome.p,
        outcome.cost,
        outcome.history,
        outcome.iterations,
        outcome.termination.to_string(),
    );
    let params = InPlaneParams::from_array(p);
    let simulated: Vec<Target> = targets
        .iter()
        .zip(&simulated_values)
        .map(|(t, &(f, c))| Target {
            force: f,
            compression: c,
            ..*t
        })
        .collect();
    let errors = ErrorReport::new(targets, &simulated);
    Ok(FitResult {
        params,
        initial,
        cost,
        cost_history: history,
        iterations,
        simulated,
        targets: targets.to_vec(),
        errors,
        model: cfg.model,
        seconds: start.elapsed().as_secs_f64(),
        termination,
    })
}
