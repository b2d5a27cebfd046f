//! Homogenized uniaxial stress–strain curves of a tile (seed 002 §7.1).
//!
//! For a stretch `s` along the unit direction `u` at angle `angle` from material x (weft 0,
//! bias π/4, warp π/2), the coarse map is `F₂ = (1 + s) u uᵀ + (1 − c) v vᵀ` with `v ⊥ u`, and
//! the compression `c` is the one at which the orthogonal stress vanishes,
//!
//! ```text
//! σ_c(c) = vᵀ P v = 0,     P = ∂Ψ/∂F₂ at equilibrium (gathered, seed 002 Eq. 10),
//! ```
//!
//! since `∂Ψ/∂c = −vᵀPv`. The curve records `{s, c, σ_s = uᵀPu}` (σ in N/m).
//!
//! The paper searches `c` with the derivative-free COBYLA; here `σ_c` is exact at every
//! equilibrium (gathered stress), and so is its slope
//!
//! ```text
//! dσ_c/dc = vᵀ (dP/dc) v,     dF₂/dc = −v vᵀ,
//! ```
//!
//! the total derivative with the fluctuations relaxing, by implicit differentiation of the
//! equilibrium ([`crate::periodic::stress_sensitivities`]). A safeguarded secant root-find
//! ([`solver::secant`]: Illinois-type regula falsi once the root is bracketed) converges in a
//! handful of warm-started solves. With [`CurveSettings::exact_slope`] it takes Newton's steps
//! with this slope instead (secant steps where a solve has no slope, e.g. at a saddle; regula
//! falsi where a Newton point leaves the bracket), in fewer solves; that is off by default (see
//! there why). Points are solved in order of `s`, each warm-started from the previous one.
//!
//! **The compression as a DOF** ([`CurveSettings::compression_dof`], default).
//! Since `∂Ψ/∂c = −vᵀPv`, the root is the stationarity of the energy in `c`, and along a tile
//! axis the no-sliding rows do not depend on `c`; so each point there is one Newton solve over
//! the fluctuations, the twists and `c` together ([`crate::periodic::solve_compressed`]), where
//! the root-find takes one solve per trial compression. On the real stockinette
//! (`tests/compression_dof.rs`, 5 stretches to 0.3 from the rest state) the weft curve took 25
//! Newton iterations against 63, the warp 23 against 67, at the same compressions (within
//! 7·10⁻⁸) and stresses (within 4·10⁻⁷ relative). The joint solve stops on its gradient in
//! `ℓ c` (`ℓ` the tile's size; 10⁻⁹ N is a few 10⁻⁷ N/m of `σ_c`); where that leaves an
//! orthogonal stress above the root-find's tolerance (at `s = 0`, where the tolerance is
//! 10⁻⁸ N/m), the root-find with the exact slope finishes from its state; where the joint
//! solve or that finish fails, the root-find runs from the point's own start as before.
//! Along the bias the no-sliding rows turn with `c`; the joint solve keeps them frozen at the
//! compression of its last pair round and is followed by one solve at the compression found,
//! under its own rows, whose orthogonal stress the same tolerance then judges (the finishing
//! root-find where it is above). On the stockinette the bias curve took 27 Newton iterations
//! against 86, every point in that one joint solve and one solve after it, at the root-find's
//! compressions within 2·10⁻⁸; at `yarn_objective`'s 10 fixed points of all eight shared
//! fabrics no bias point needed the finishing root-find (one joint solve failed and fell back
//! to it). Where several states of zero orthogonal stress are within reach (jammed or
//! snapping tiles, far from any fit), the root-find and the joint solve can end on different
//! ones: the joint solve ends where the energy is a minimum in `c` as well, the state a free
//! edge relaxes to.

use crate::coarse::Coarse;
use crate::periodic::{
    Equilibrium, EquilibriumSettings, PeriodicError, YarnModel, equilibrium_problem,
    solve_compressed, solve_equilibrium, stress_sensitivities,
};
use nalgebra::Vector2;
use solver::{SecantError, SecantEval, SecantSettings, SolveError, StepError, secant};
use yarn_pattern::direction::Direction;
use yarn_pattern::tile::Tile;

/// Settings of a curve.
#[derive(Clone, Debug)]
pub struct CurveSettings {
    /// Settings of every equilibrium solve.
    pub equilibrium: EquilibriumSettings,
    /// Root found when `|σ_c| ≤ stress_abs_tol + stress_rel_tol · |σ_s|` (N/m). Defaults
    /// `1e-8` N/m and `1e-6`.
    pub stress_abs_tol: f64,
    /// See [`CurveSettings::stress_abs_tol`].
    pub stress_rel_tol: f64,
    /// Most equilibrium solves per point. Default 30.
    pub max_solves: usize,
    /// A compression is also accepted once a sign change of `σ_c` is bracketed to this width
    /// (unitless): where the tile snaps between equilibria, `σ_c` jumps across zero and has
    /// no root, and the bracket locates the jump. The point's `sigma_c` is then the stress
    /// on one side of it. Default `1e-7`, far below the accuracy of measured compressions
    /// (10⁻³).
    pub compression_tol: f64,
    /// Newton steps on `c` with the exact slope `dσ_c/dc` of every solve (module
    /// documentation), instead of secant steps. Default `false`.
    ///
    /// A slope costs one assembly, factorization and solve with the equilibrium's Hessian
    /// (and the structures they are built on), and is computed only where the point is not
    /// yet a root. On the
    /// `yarn-fit` objective of the acrylic seed at its fitted point (20 stress samples and
    /// 3 × 3 compression nodes; release, one thread, three interleaved runs of 5 evaluations
    /// each) it took Newton iterations per evaluation from 684 to 617 and the time from 1.98
    /// to 1.78 s, with the objective equal to 6 digits (0.0385085 both). The criterion bench
    /// `cargo bench -p sim-periodic --bench equilibrium -- "weft curve"` (the real stockinette's
    /// weft curve at 5 stretches) takes 17 solves instead of 26, but its times were within this
    /// machine's noise: 798 against 741 ms in one run, 881 against 987 ms in the next.
    ///
    /// It is off by default because a full `yarn-fit` run with it (against the committed run
    /// before it, same machine) was not faster end to end, and its fits
    /// went elsewhere. The roots agree with the secant's to within 1e-6 (the stockinette weft
    /// curve of `tests/database.rs`), but which solves fail changes too, and the swarm and the
    /// local starts followed other paths:
    ///
    /// | fabric | g (secant → Newton) | comfort-range error | failed evaluations | fit time |
    /// |---|---|---|---|---|
    /// | acrylic garter | 0.089 → 0.209 | 5.8 → 17.2 % | 3 → 10 | 187 → 218 s |
    /// | acrylic rib | 0.153 → 0.120 | 11.6 → 14.3 % | 14 → 28 | 260 → 246 s |
    /// | acrylic seed | 0.039 → 0.090 | 5.9 → 10.5 % | 5 → 11 | 591 → 615 s |
    /// | acrylic stockinette (development) | 0.073 → 0.071 | 10.6 → 7.8 % | 7 → 5 | 75 → 56 s |
    /// | babyredo garter | 0.627 → 0.212 | 13.6 → 20.5 % | 17 → 14 | 194 → 172 s |
    /// | babyredo rib | 0.068 → 0.076 | 5.7 → 9.0 % | 19 → 13 | 486 → 373 s |
    /// | babyredo seed | 0.237 → 0.492 | 7.5 → 12.4 % | 25 → 37 | 340 → 478 s |
    /// | babyredo stockinette | 0.0755 → 0.0755 | 14.7 → 14.7 % | 4 → 4 | 77 → 60 s |
    ///
    /// Failed evaluations (no equilibrium: +∞ to the swarm) rose from 94 to 122 in all; a likely cause, not checked, is that a Newton
    /// step may jump up to 0.2 in `c`, into jammed states that the secant's first probe of
    /// 0.01 does not reach. The held-out fabrics' mean comfort-range error went from 9.3 to
    /// 14.1 %. That spread says as much about how strongly one fit depends on its path as
    /// about this setting: on the development fabric, changing only the swarm's seed already
    /// moved g between 0.073 and 0.157 (`bench::figures::yarn_fit`'s seed study).
    pub exact_slope: bool,
    /// Solve each point in one Newton solve with the compression as a DOF
    /// ([`crate::periodic::solve_compressed`]; along the bias under frozen no-sliding rows,
    /// then one solve at the compression found) instead of the root-find over solves at fixed
    /// compressions (module documentation). Default `true`.
    pub compression_dof: bool,
}

impl CurveSettings {
    /// The root-find's tolerance on `|σ_c|` at stretch stress `sigma_s`:
    /// `stress_abs_tol + stress_rel_tol · |σ_s|` (N/m).
    pub fn stress_tolerance(&self, sigma_s: f64) -> f64 {
        self.stress_abs_tol + self.stress_rel_tol * sigma_s.abs()
    }
}

impl Default for CurveSettings {
    fn default() -> Self {
        Self {
            equilibrium: EquilibriumSettings::default(),
            stress_abs_tol: 1e-8,
            stress_rel_tol: 1e-6,
            max_solves: 30,
            compression_tol: 1e-7,
            exact_slope: false,
            compression_dof: true,
        }
    }
}

/// One point of a uniaxial curve.
#[derive(Clone, Debug)]
pub struct CurvePoint {
    /// Stretch `s` (unitless).
    pub s: f64,
    /// Orthogonal compression `c` at zero orthogonal stress (unitless, positive = narrower).
    pub c: f64,
    /// Stretch stress `σ_s = uᵀPu` (N/m).
    pub sigma_s: f64,
    /// Remaining orthogonal stress `vᵀPv` (N/m), within tolerance of 0.
    pub sigma_c: f64,
    /// Energy density Ψ (J/m²).
    pub density: f64,
    /// Equilibrium solves used by the root-find; a joint solve with the compression as a DOF
    /// counts as one (along the bias with the solve after it).
    pub solves: usize,
    /// Newton iterations summed over those solves.
    pub iterations: usize,
}

/// Errors of curve computation.
#[derive(Debug, thiserror::Error)]
pub enum CurveError {
    /// An equilibrium solve failed.
    #[error("{direction} stretch s = {s}, compression c = {c}: {source}")]
    Solve {
        /// Direction name.
        direction: &'static str,
        /// Stretch.
        s: f64,
        /// Compression tried.
        c: f64,
        /// Solver error.
        source: PeriodicError,
    },
    /// The root-find did not converge.
    #[error(
        "{direction} stretch s = {s}: orthogonal stress did not vanish after {solves} solves \
         (best |σ_c| = {best} N/m at c = {c})"
    )]
    RootFind {
        /// Direction name.
        direction: &'static str,
        /// Stretch.
        s: f64,
        /// Best compression.
        c: f64,
        /// Its residual stress.
        best: f64,
        /// Solves used.
        solves: usize,
    },
    /// Invalid input.
    #[error("invalid curve input: {0}")]
    Invalid(String),
}

/// Stretch and orthogonal stress `(uᵀPu, vᵀPv)` of an equilibrium along `angle`.
pub fn directional_stress(eq: &Equilibrium, angle: f64) -> (f64, f64) {
    let u = Vector2::new(angle.cos(), angle.sin());
    let v = Vector2::new(-u.y, u.x);
    (u.dot(&(eq.stress * u)), v.dot(&(eq.stress * v)))
}

/// The uniaxial curve of `tile` along `direction` at the stretches `stretches` (solved in the
/// given order, each warm-started from the previous point; start at or near 0 and move
/// outward for robust continuation).
pub fn uniaxial_curve(
    tile: &Tile,
    model: &YarnModel,
    direction: Direction,
    stretches: &[f64],
    settings: &CurveSettings,
) -> Result<Vec<CurvePoint>, CurveError> {
    Ok(
        uniaxial_curve_states(tile, model, direction, stretches, settings)?
            .into_iter()
            .map(|(point, _)| point)
            .collect(),
    )
}

/// [`uniaxial_curve`] with the equilibrium of every point.
pub fn uniaxial_curve_states(
    tile: &Tile,
    model: &YarnModel,
    direction: Direction,
    stretches: &[f64],
    settings: &CurveSettings,
) -> Result<Vec<(CurvePoint, Equilibrium)>, CurveError> {
    if let Some(bad) = stretches.iter().find(|s| !(s.is_finite() && **s > -1.0)) {
        return Err(CurveError::Invalid(format!(
            "stretch {bad} must be finite and > -1"
        )));
    }
    let along = Along {
        tile,
        model,
        angle: direction.angle(),
        name: direction.name(),
    };
    let mut warm: Option<Vec<f64>> = None;
    let mut c_prev = 0.0;
    let mut slope = 0.0; // dc/ds of the previous step
    let mut s_prev = 0.0;
    let mut out: Vec<(CurvePoint, Equilibrium)> = Vec::with_capacity(stretches.len());
    for &s in stretches {
        let guess = (c_prev + slope * (s - s_prev)).min(0.9);
        let point = along.point(s, guess, warm.as_deref(), settings)?;
        if let Some(last) = out.last() {
            let last: &CurvePoint = &last.0;
            if (s - last.s).abs() > 0.0 {
                slope = (point.0.c - last.c) / (s - last.s);
            }
        }
        c_prev = point.0.c;
        s_prev = s;
        warm = Some(point.1.dofs.clone());
        out.push(point);
    }
    Ok(out)
}

/// Largest compression a root-find tries.
const COMPRESSION_BOUND: f64 = 0.95;

/// A tile, its yarn model and the direction of one curve: what its points share.
#[derive(Clone, Copy)]
struct Along<'a> {
    tile: &'a Tile,
    model: &'a YarnModel,
    angle: f64,
    name: &'static str,
}

impl Along<'_> {
    /// The point at stretch `s` from `guess` and `warm`: [`Along::compression_dof_point`] with
    /// [`CurveSettings::compression_dof`], else [`Along::root_find`].
    fn point(
        &self,
        s: f64,
        guess: f64,
        warm: Option<&[f64]>,
        settings: &CurveSettings,
    ) -> Result<(CurvePoint, Equilibrium), CurveError> {
        if settings.compression_dof {
            self.compression_dof_point(s, guess, warm, settings)
        } else {
            self.root_find(s, guess, warm, settings)
        }
    }

    /// The point at stretch `s` from one solve with the compression as a DOF
    /// ([`solve_compressed`], from `guess` and `warm`). Along a tile axis its stationarity
    /// tolerance in `c` is the solver's gradient tolerance on `ℓ c`; along the bias the solve
    /// predicts the root under frozen no-sliding rows and re-solves at it. Where the orthogonal
    /// stress it leaves is above the root-find's tolerance, [`Along::root_find`] with the
    /// exact slope finishes from there (one solve at that compression and, usually, one Newton
    /// step). Where the solve or that finish fails, or the compression is past the root-find's
    /// bound (0.95), the root-find runs from `guess` and `warm` instead.
    fn compression_dof_point(
        &self,
        s: f64,
        guess: f64,
        warm: Option<&[f64]>,
        settings: &CurveSettings,
    ) -> Result<(CurvePoint, Equilibrium), CurveError> {
        let Self {
            tile, model, angle, ..
        } = *self;
        let (c, eq) =
            match solve_compressed(tile, model, s, angle, guess, warm, &settings.equilibrium) {
                Ok((c, eq)) if c <= COMPRESSION_BOUND => (c, eq),
                _ => return self.root_find(s, guess, warm, settings),
            };
        let (sigma_s, sigma_c) = directional_stress(&eq, angle);
        if sigma_c.abs() <= settings.stress_tolerance(sigma_s) {
            let point = CurvePoint {
                s,
                c,
                sigma_s,
                sigma_c,
                density: eq.density,
                solves: 1,
                iterations: eq.iterations,
            };
            return Ok((point, eq));
        }
        let polish = CurveSettings {
            exact_slope: true,
            ..settings.clone()
        };
        match self.root_find(s, c, Some(&eq.dofs), &polish) {
            Ok((mut point, eq_root)) => {
                point.solves += 1;
                point.iterations += eq.iterations;
                Ok((point, eq_root))
            }
            Err(_) => self.root_find(s, guess, warm, settings),
        }
    }

    /// The compression at which `σ_c` vanishes for stretch `s`: [`solver::secant`] from `guess`
    /// (Newton steps with [`compression_slope`] where [`CurveSettings::exact_slope`], else a second
    /// point 0.01 away and secant steps; steps of at most 0.2 clipped to `c ≤ 0.95`, a trial
    /// compression without a reachable equilibrium — a jammed state where Newton stalls against the
    /// collision filter — retried up to 4 times closer to the last good one), every evaluation an
    /// equilibrium solve warm-started from the last one.
    fn root_find(
        &self,
        s: f64,
        guess: f64,
        warm: Option<&[f64]>,
        settings: &CurveSettings,
    ) -> Result<(CurvePoint, Equilibrium), CurveError> {
        let Self {
            tile,
            model,
            angle,
            name,
        } = *self;
        let mut solves = 0;
        let mut iterations = 0;
        let mut last_dofs: Option<Vec<f64>> = warm.map(<[f64]>::to_vec);
        // Evaluates σ_c at compression c (warm-started from the last solve).
        let eval = |c: f64| -> Result<SecantEval<(f64, Equilibrium)>, StepError<CurveError>> {
            let coarse = Coarse::uniaxial(s, c, angle);
            let eq = solve_equilibrium(
                tile,
                model,
                coarse,
                last_dofs.as_deref(),
                &settings.equilibrium,
            )
            .map_err(|source| {
                StepError::Halve(CurveError::Solve {
                    direction: name,
                    s,
                    c,
                    source,
                })
            })?;
            solves += 1;
            iterations += eq.iterations;
            last_dofs = Some(eq.dofs.clone());
            let (ss, sc) = directional_stress(&eq, angle);
            let f_tol = settings.stress_tolerance(ss);
            // A converged point needs no next step, so no slope.
            let df = if settings.exact_slope && sc.abs() > f_tol {
                compression_slope(tile, model, &eq, angle).map_err(|source| {
                    StepError::Abort(CurveError::Solve {
                        direction: name,
                        s,
                        c,
                        source,
                    })
                })?
            } else {
                None
            };
            Ok(SecantEval {
                f: sc,
                f_tol,
                data: (ss, eq),
                df,
            })
        };
        let secant_settings = SecantSettings {
            first_step: 0.01,
            max_step: 0.2,
            lower: f64::NEG_INFINITY,
            upper: COMPRESSION_BOUND,
            max_iterations: settings.max_solves,
            max_retries: 4,
            x_tol: settings.compression_tol,
        };
        let root = match secant(guess, &secant_settings, eval) {
            Ok(root) => root,
            Err(SecantError::Eval { source, .. }) => return Err(source),
            Err(SecantError::NotConverged(r) | SecantError::NonFinite(r)) => {
                return Err(CurveError::RootFind {
                    direction: name,
                    s,
                    c: r.x,
                    best: r.best_abs_f(),
                    solves,
                });
            }
            Err(SecantError::InvalidInput(msg)) => return Err(CurveError::Invalid(msg)),
        };
        let (sigma_s, eq) = root.data;
        let point = CurvePoint {
            s,
            c: root.x,
            sigma_s,
            sigma_c: root.f,
            density: eq.density,
            solves,
            iterations,
        };
        Ok((point, eq))
    }
}

/// The slope `dσ_c/dc` (N/m) of the orthogonal stress at the equilibrium `eq` under the
/// uniaxial map at `angle`, the fluctuations relaxing (module documentation); `None` where the
/// sensitivities do not exist (the equilibrium is not a strict constrained minimum: the
/// solver's `NotAStrictMinimum`), and the root-find takes a secant step instead. Any other
/// failure is an error.
fn compression_slope(
    tile: &Tile,
    model: &YarnModel,
    eq: &Equilibrium,
    angle: f64,
) -> Result<Option<f64>, PeriodicError> {
    let v = Vector2::new(-angle.sin(), angle.cos());
    let problem = equilibrium_problem(tile, model, eq)?;
    let partial = problem.coarse_partial(&eq.dofs, &(-(v * v.transpose())))?;
    match stress_sensitivities(&problem, &eq.dofs, &[partial]) {
        Ok(total) => Ok(Some(v.dot(&(total[0] * v)))),
        Err(PeriodicError::Solve(SolveError::NotAStrictMinimum(_))) => Ok(None),
        Err(e) => Err(e),
    }
}

/// One point of a bending curve.
#[derive(Clone, Debug)]
pub struct BendingPoint {
    /// Curvature κ (1/m).
    pub kappa: f64,
    /// Energy density Ψ (J/m²) at κ.
    pub density: f64,
    /// Bending stress `σ_κ = dΨ/dκ` (N = J/m), by central differences of the equilibrium
    /// energy density over `κ ± h`.
    pub moment: f64,
}

/// The bending curve of `tile` curved along `axis` (0 = x / weft, 1 = y / warp) at the
/// curvatures `kappas` (1/m, solved in order with warm starts), with the bending stress
/// `dΨ/dκ` from central differences with step `h` (1/m). In-plane the tile is unstretched.
pub fn bending_curve(
    tile: &Tile,
    model: &YarnModel,
    axis: usize,
    kappas: &[f64],
    h: f64,
    settings: &EquilibriumSettings,
) -> Result<Vec<BendingPoint>, CurveError> {
    if axis > 1 || !(h > 0.0 && h.is_finite()) {
        return Err(CurveError::Invalid(format!(
            "bending axis must be 0 or 1 and the step positive (got {axis}, {h})"
        )));
    }
    let name = if axis == 0 {
        "weft bending"
    } else {
        "warp bending"
    };
    let mut warm: Option<Vec<f64>> = None;
    let solve = |k: f64, warm: &mut Option<Vec<f64>>| -> Result<Equilibrium, CurveError> {
        let coarse = Coarse::identity().bent(axis, k);
        let eq = solve_equilibrium(tile, model, coarse, warm.as_deref(), settings).map_err(
            |source| CurveError::Solve {
                direction: name,
                s: k,
                c: 0.0,
                source,
            },
        )?;
        *warm = Some(eq.dofs.clone());
        Ok(eq)
    };
    let mut out = Vec::with_capacity(kappas.len());
    for &k in kappas {
        if !k.is_finite() {
            return Err(CurveError::Invalid(format!("curvature {k} is not finite")));
        }
        let centre = solve(k, &mut warm)?;
        let mut side = warm.clone();
        let plus = solve(k + h, &mut side)?;
        let mut side = warm.clone();
        let minus = solve(k - h, &mut side)?;
        out.push(BendingPoint {
            kappa: k,
            density: centre.density,
            moment: (plus.density - minus.density) / (2.0 * h),
        });
    }
    Ok(out)
}
