//! The bending fit of seed 002 §5.2 (Fig. 8) by simulation in the loop:
//!
//! ```text
//! k_bending = argmin Σ_i ( r(k_bending, d_i) − r_i )²,   k_bending = {k_θ,weft, k_θ,bias, k_θ,warp}
//! ```
//!
//! with `7` pear-loop targets per direction at inter-clamp distances `d_i` evenly spread from
//! 3.4 cm down to 0.3 cm ([`target_distances`]); `r = h/p` is the loop's aspect ratio from
//! [`crate::pear_loop`] (gravity, no contact).
//!
//! **Which parameter a test sees.** `k_θ` is interpolated by the *rest direction of the hinge
//! edge* (Eq. 4, [`BendingParams::stiffness`]). A pear loop whose strip runs along direction
//! `α` bends about hinges *across* the strip, i.e. edges at `α + 90°`: the weft loop is governed
//! by `k_θ,warp`, the warp loop by `k_θ,weft`, the bias loop by `k_θ,bias` (edges at 135°). The
//! fit handles this automatically (it fits all three against all targets), but it matters when
//! reading the parameters; [`crate::curves::bending_curve`] uses the `k_θ` of edges *along* the
//! curve's direction.
//!
//! **Derivatives.** Each residual's gradient comes from implicit differentiation of the
//! pear-loop equilibrium ([`PearLoop::ratio_sensitivity`]: one sparse LU of the exact Hessian
//! per target, one back-substitution, `∂g/∂k_j` exact because the hinge energy is linear in
//! `k`), not from finite differences.
//!
//! **Optimizer.** The bounded Levenberg–Marquardt of [`solver::lm`] (as in [`crate::fit`]) in the parameters
//! `ln k_j` (positivity for free, and `r` depends on `k` roughly through `ln k`, since the
//! gravity bending length is `∝ k^{1/3}`), with bounds `[lower, upper]` (N·m) mapped to log
//! space. A trial point whose equilibria fail is rejected (damping grows); a failure at the
//! initial guess is an error.

use std::time::Instant;
use yarn_pattern::direction::Direction;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::ShellError;
use crate::elements::BendingParams;
use crate::fit::{Progress, lm_error};
use crate::material::{InPlaneParams, Material};
use crate::pear_loop::{PearLoop, PearLoopConfig};

use solver::{LmBounds, LmEval, LmSettings, bounded_lm};

/// One bending target: a pear-loop aspect ratio at a clamp distance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BendingTarget {
    /// Direction of the strip's long axis.
    pub direction: Direction,
    /// Inter-clamp distance `d` (m).
    pub d: f64,
    /// Measured aspect ratio `r = h/p`.
    pub ratio: f64,
}

/// Largest and smallest clamp distance of the protocol (m).
pub const D_RANGE: (f64, f64) = (0.034, 0.003);

/// `n ≥ 2` clamp distances evenly spread from 3.4 cm down to 0.3 cm (both included), m.
pub fn target_distances(n: usize) -> Vec<f64> {
    let (a, b) = D_RANGE;
    if n < 2 {
        return vec![a; n];
    }
    (0..n)
        .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
        .collect()
}

/// Settings of [`fit_bending`].
#[derive(Clone, Debug, PartialEq)]
pub struct BendingFitConfig {
    /// Pear-loop geometry, mesh and Newton settings.
    pub pear: PearLoopConfig,
    /// In-plane material of the strip (fixed during the bending fit, e.g. from the in-plane
    /// fit). Default [`InPlaneParams::example`] with the augmented model.
    pub material: Material,
    /// Lower bounds on `[weft, bias, warp]` (N·m). Default `1e-12` each.
    pub lower: [f64; 3],
    /// Upper bounds (N·m). Default `1e-2` each.
    pub upper: [f64; 3],
    /// Parameters held at their initial value (e.g. `bias` without a bias test). Default none.
    pub fixed: [bool; 3],
    /// Maximum LM iterations (accepted or rejected). Default 40.
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction. Default `1e-12`.
    pub cost_rtol: f64,
    /// Stop when the step in `ln k` is smaller than this. Default `1e-9`.
    pub step_tol: f64,
    /// Stop when every `|r_sim − r_i|` is at most this (the targets are matched to solver
    /// precision; further iterations only chase equilibrium-solve noise). Default `1e-8`.
    pub ratio_tol: f64,
}

impl Default for BendingFitConfig {
    fn default() -> Self {
        Self {
            pear: PearLoopConfig::default(),
            material: Material::augmented(InPlaneParams::example()),
            lower: [1e-12; 3],
            upper: [1e-2; 3],
            fixed: [false; 3],
            max_iterations: 40,
            cost_rtol: 1e-12,
            step_tol: 1e-9,
            ratio_tol: 1e-8,
        }
    }
}

/// Per-direction fit quality.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BendingDirectionError {
    /// Direction.
    pub direction: Direction,
    /// Mean of `|r_sim − r_i| / r_i` over the direction's targets.
    pub ratio_rel_error: f64,
}

/// Result of [`fit_bending`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BendingFitResult {
    /// Fitted `{k_θ,weft, k_θ,bias, k_θ,warp}` (N·m).
    pub params: BendingParams,
    /// Initial guess (N·m).
    pub initial: BendingParams,
    /// Final cost `Σ (r_sim − r_i)²`.
    pub cost: f64,
    /// Cost after every accepted step (first entry: the initial guess).
    pub cost_history: Vec<f64>,
    /// LM iterations (accepted and rejected).
    pub iterations: usize,
    /// The targets.
    pub targets: Vec<BendingTarget>,
    /// Simulated ratios at the targets with the fitted parameters.
    pub simulated: Vec<BendingTarget>,
    /// Errors per direction.
    pub errors: Vec<BendingDirectionError>,
    /// Mean relative ratio error over all targets.
    pub ratio_rel_error: f64,
    /// Wall time (s).
    pub seconds: f64,
    /// Why it stopped.
    pub termination: String,
}

/// One pear loop per direction, warm-started from the equilibria of the last accepted
/// evaluation.
struct DirectionLoop {
    direction: Direction,
    pear: Option<PearLoop>,
    /// Target indices in order of decreasing `d` (the order of the physical test).
    idx: Vec<usize>,
    states: Vec<Option<Vec<f64>>>,
}

/// Simulated ratios (and optionally `dr/dk`) at the targets; the new equilibria per direction.
type BendingEval = (Vec<f64>, Option<Vec<[f64; 3]>>, Vec<Vec<Vec<f64>>>);

/// Maps bending parameters to simulated pear-loop ratios at a set of targets.
pub struct BendingSimulator {
    cfg: PearLoopConfig,
    material: Material,
    dirs: Vec<DirectionLoop>,
    n: usize,
}

impl BendingSimulator {
    /// One pear loop per direction present in `targets` (built lazily at the first
    /// evaluation).
    pub fn new(cfg: &PearLoopConfig, material: Material, targets: &[BendingTarget]) -> Self {
        let mut dirs = Vec::new();
        for direction in Direction::ALL {
            let mut idx: Vec<usize> = (0..targets.len())
                .filter(|&i| targets[i].direction == direction)
                .collect();
            if idx.is_empty() {
                continue;
            }
            idx.sort_by(|&a, &b| targets[b].d.total_cmp(&targets[a].d));
            dirs.push(DirectionLoop {
                direction,
                pear: None,
                states: vec![None; idx.len()],
                idx,
            });
        }
        Self {
            cfg: cfg.clone(),
            material,
            dirs,
            n: targets.len(),
        }
    }

    fn evaluate(
        &mut self,
        b: &BendingParams,
        targets: &[BendingTarget],
        with_jac: bool,
    ) -> Result<BendingEval, ShellError> {
        let mut sim = vec![0.0; self.n];
        let mut jac = with_jac.then(|| vec![[0.0; 3]; self.n]);
        let mut all_states = Vec::with_capacity(self.dirs.len());
        for dl in &mut self.dirs {
            let d_first = targets[dl.idx[0]].d;
            let mut fresh = false;
            let pear = match dl.pear.as_mut() {
                Some(p) => {
                    p.set_bending(*b)?;
                    p
                }
                None => {
                    fresh = true;
                    dl.pear.insert(PearLoop::new(
                        &self.cfg,
                        self.material,
                        *b,
                        dl.direction.angle(),
                        d_first,
                    )?)
                }
            };
            let mut new_states: Vec<Vec<f64>> = Vec::with_capacity(dl.idx.len());
            for (j, &ti) in dl.idx.iter().enumerate() {
                let d = targets[ti].d;
                let mut shape = None;
                if j == 0 && fresh {
                    shape = Some(pear.shape());
                } else if let Some(x) = &dl.states[j] {
                    pear.set_state(d, x)?;
                    shape = pear.equilibrate().ok();
                }
                let shape = match shape {
                    Some(s) => s,
                    None if j > 0 => {
                        pear.set_state(targets[dl.idx[j - 1]].d, &new_states[j - 1])?;
                        pear.solve_to(d)?
                    }
                    None => {
                        // Restart from the U-shaped initial guess.
                        *pear =
                            PearLoop::new(&self.cfg, self.material, *b, dl.direction.angle(), d)?;
                        pear.shape()
                    }
                };
                sim[ti] = shape.ratio;
                if let Some(jac) = jac.as_mut() {
                    jac[ti] = pear.ratio_sensitivity()?;
                }
                new_states.push(pear.positions().to_vec());
            }
            all_states.push(new_states);
        }
        Ok((sim, jac, all_states))
    }

    fn commit(&mut self, states: Vec<Vec<Vec<f64>>>) {
        for (dl, s) in self.dirs.iter_mut().zip(states) {
            dl.states = s.into_iter().map(Some).collect();
        }
    }

    /// Simulated ratios at every target for `b` (warm-started from the previous call).
    pub fn simulate(
        &mut self,
        b: &BendingParams,
        targets: &[BendingTarget],
    ) -> Result<Vec<f64>, ShellError> {
        let (sim, _, states) = self.evaluate(b, targets, false)?;
        self.commit(states);
        Ok(sim)
    }

    /// Simulated ratios and their sensitivities `dr/dk` (`[weft, bias, warp]`, 1/(N·m)) at
    /// every target.
    pub fn simulate_with_sensitivities(
        &mut self,
        b: &BendingParams,
        targets: &[BendingTarget],
    ) -> Result<(Vec<f64>, Vec<[f64; 3]>), ShellError> {
        let (sim, jac, states) = self.evaluate(b, targets, true)?;
        self.commit(states);
        Ok((sim, jac.expect("requested")))
    }
}

/// Virtual pear-loop data: the simulated ratio at clamp distances `ds` (m) for every direction
/// in `directions`, with bending parameters `b`.
pub fn virtual_targets(
    cfg: &PearLoopConfig,
    material: Material,
    b: &BendingParams,
    directions: &[Direction],
    ds: &[f64],
) -> Result<Vec<BendingTarget>, ShellError> {
    let mut targets: Vec<BendingTarget> = directions
        .iter()
        .flat_map(|&direction| {
            ds.iter().map(move |&d| BendingTarget {
                direction,
                d,
                ratio: f64::NAN,
            })
        })
        .collect();
    let sim = BendingSimulator::new(cfg, material, &targets).simulate(b, &targets)?;
    for (t, r) in targets.iter_mut().zip(sim) {
        t.ratio = r;
    }
    Ok(targets)
}

/// Fits `{k_θ,weft, k_θ,bias, k_θ,warp}` to pear-loop `targets` from `initial` (see the module
/// docs).
pub fn fit_bending(
    targets: &[BendingTarget],
    initial: BendingParams,
    cfg: &BendingFitConfig,
    progress: Option<Progress<'_>>,
) -> Result<BendingFitResult, ShellError> {
    let start = Instant::now();
    if targets.is_empty() {
        return Err(ShellError::InvalidInput("no bending targets".into()));
    }
    if let Some(t) = targets
        .iter()
        .find(|t| !(t.d.is_finite() && t.d > 0.0 && t.ratio.is_finite() && t.ratio > 0.0))
    {
        return Err(ShellError::InvalidInput(format!(
            "bending target needs finite d > 0 and r > 0, got {t:?}"
        )));
    }
    let p0 = initial.to_array();
    if !p0.iter().all(|k| k.is_finite() && *k > 0.0) {
        return Err(ShellError::InvalidInput(format!(
            "initial bending stiffnesses must be finite and > 0, got {initial:?}"
        )));
    }
    if !(0..3).all(|j| cfg.lower[j] > 0.0 && cfg.lower[j] <= cfg.upper[j]) {
        return Err(ShellError::InvalidInput(format!(
            "bending bounds need 0 < lower ≤ upper, got {:?} … {:?}",
            cfg.lower, cfg.upper
        )));
    }
    let sim = std::cell::RefCell::new(BendingSimulator::new(&cfg.pear, cfg.material, targets));
    let m = targets.len();
    /// Simulated ratios and the equilibria per direction, committed on acceptance.
    type Accepted = (Vec<f64>, Vec<Vec<Vec<f64>>>);
    let mut eval = |q: &[f64; 3]| -> Result<LmEval<Accepted>, ShellError> {
        let k: [f64; 3] = std::array::from_fn(|j| q[j].exp());
        let (r, dr, states) =
            sim.borrow_mut()
                .evaluate(&BendingParams::from_array(k), targets, true)?;
        let dr = dr.expect("requested");
        let res = DVector::from_fn(m, |i, _| r[i] - targets[i].ratio);
        // Columns in ln k: dr/d(ln k) = k dr/dk.
        let jac = DMatrix::from_fn(m, 3, |i, j| dr[i][j] * k[j]);
        Ok((res, jac, (r, states)))
    };
    let mut ratios = Vec::new();
    let mut commit = |(r, states): Accepted, _: &mut DMatrix<f64>| {
        sim.borrow_mut().commit(states);
        ratios = r;
        Ok(())
    };
    let outcome = bounded_lm(
        p0.map(f64::ln),
        &LmBounds {
            lower: cfg.lower.map(f64::ln),
            upper: cfg.upper.map(f64::ln),
            fixed: cfg.fixed,
            scale: [1.0; 3],
        },
        &LmSettings {
            max_iterations: cfg.max_iterations,
            cost_rtol: cfg.cost_rtol,
            step_tol: cfg.step_tol,
            residual_tol: cfg.ratio_tol,
        },
        &|_| {},
        &mut eval,
        &mut commit,
        progress,
    )
    .map_err(lm_error)?;
    let params = BendingParams::from_array(outcome.p.map(f64::exp));
    let simulated: Vec<BendingTarget> = targets
        .iter()
        .zip(&ratios)
        .map(|(t, &ratio)| BendingTarget { ratio, ..*t })
        .collect();
    let rel = |s: &BendingTarget, t: &BendingTarget| (s.ratio - t.ratio).abs() / t.ratio;
    let errors = Direction::ALL
        .iter()
        .filter_map(|&direction| {
            let e: Vec<f64> = targets
                .iter()
                .zip(&simulated)
                .filter(|(t, _)| t.direction == direction)
                .map(|(t, s)| rel(s, t))
                .collect();
            (!e.is_empty()).then(|| BendingDirectionError {
                direction,
                ratio_rel_error: e.iter().sum::<f64>() / e.len() as f64,
            })
        })
        .collect();
    let ratio_rel_error = targets
        .iter()
        .zip(&simulated)
        .map(|(t, s)| rel(s, t))
        .sum::<f64>()
        / m as f64;
    Ok(BendingFitResult {
        params,
        initial,
        cost: outcome.cost,
        cost_history: outcome.history,
        iterations: outcome.iterations,
        targets: targets.to_vec(),
        simulated,
        errors,
        ratio_rel_error,
        seconds: start.elapsed().as_secs_f64(),
        termination: outcome.termination.to_string(),
    })
}

/// Reads pear-loop targets from a CSV with the header `direction,d,r` (direction `weft`,
/// `bias` or `warp` as accepted by [`Direction::parse`]; clamp distance `d` in m; ratio
/// `r = h/p`). Blank lines and lines starting with `#` are skipped. Errors name the file, the
/// line and the problem.
pub fn read_bending_csv(path: &std::path::Path) -> Result<Vec<BendingTarget>, ShellError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| ShellError::Io {
        file: file.clone(),
        source,
    })?;
    parse_bending_csv(&text, &file)
}

/// [`read_bending_csv`] on CSV `text`; `file` names the source in errors.
pub fn parse_bending_csv(text: &str, file: &str) -> Result<Vec<BendingTarget>, ShellError> {
    let file = file.to_string();
    let err = |line: usize, problem: String| ShellError::Data {
        file: file.clone(),
        line,
        problem,
    };
    let records = crate::csv_io::records(text, &file)?;
    let Some((head, rows)) = records.split_first() else {
        return Err(err(0, "no bending targets".into()));
    };
    let names: Vec<String> = head.fields.iter().map(|c| c.to_ascii_lowercase()).collect();
    if names != ["direction", "d", "r"] {
        return Err(err(
            head.line,
            format!(
                "expected the header `direction,d,r`, found `{}`",
                head.fields.join(",")
            ),
        ));
    }
    let mut out = Vec::new();
    for crate::csv_io::Record { line, fields: cols } in rows {
        let line = *line;
        if cols.len() != 3 {
            return Err(err(
                line,
                format!("expected 3 columns, found {}", cols.len()),
            ));
        }
        let direction = Direction::parse(&cols[0])
            .ok_or_else(|| err(line, format!("unknown direction `{}`", cols[0])))?;
        let num = |c: &str, what: &str| -> Result<f64, ShellError> {
            let v: f64 = c
                .parse()
                .map_err(|_| err(line, format!("{what} `{c}` is not a number")))?;
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(err(line, format!("{what} must be finite and > 0, got {v}")))
            }
        };
        let d = num(&cols[1], "clamp distance d")?;
        if d > 0.05 {
            return Err(err(
                line,
                format!(
                    "clamp distance d = {d} m is implausible (metres expected, protocol 0.003 … 0.034)"
                ),
            ));
        }
        let ratio = num(&cols[2], "ratio r")?;
        out.push(BendingTarget {
            direction,
            d,
            ratio,
        });
    }
    if out.is_empty() {
        return Err(err(0, "no bending targets".into()));
    }
    Ok(out)
}

/// The initial guess the CLI starts the bending fit from, `k_θ = 1e-6` N·m in every direction
/// (a gravity bending length of about 2 cm on the default strip).
pub const DEFAULT_INITIAL: BendingParams = BendingParams {
    weft: 1e-6,
    bias: 1e-6,
    warp: 1e-6,
};

/// Which of `[weft, bias, warp]` no test in `directions` identifies (to hold fixed): the
/// pear loop along the weft is governed by `k_θ,warp` (its hinges run along the warp), the
/// bias loop by `k_θ,bias`, the warp loop by `k_θ,weft` (see the module docs).
pub fn unidentified(directions: &[Direction]) -> [bool; 3] {
    [
        !directions.contains(&Direction::Warp),
        !directions.contains(&Direction::Bias),
        !directions.contains(&Direction::Weft),
    ]
}
