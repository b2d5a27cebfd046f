//! Equilibrium solves: initial DOFs, settings, and the solve loop that rebuilds contact pairs.

use super::{ContactPair, PeriodicError, PeriodicTile, YarnModel};
use crate::coarse::Coarse;
use nalgebra::{Matrix2, Vector2};
use solver::{LinearConstraints, NewtonSettings, Problem, minimize_constrained};
use yarn_pattern::strain::sqrt_spd2;
use yarn_pattern::tile::Tile;

/// Initial DOFs of a tile: zero fluctuation, the tile's twist angles (`*Q`'s `t` column
/// belongs to the edge starting at each vertex).
pub fn initial_dofs(tile: &Tile) -> Result<Vec<f64>, PeriodicError> {
    let topology = tile.topology()?;
    let n = tile.n_vertices();
    let mut x = vec![0.0; 4 * n];
    for v in 0..n {
        x[3 * n + topology.outgoing(v)] = tile.twists[v];
    }
    Ok(x)
}

/// Iterations without progress after which an equilibrium solve fails
/// ([`solver::NewtonSettings::stall_iterations`]: the residual not halved and the energy not
/// lowered beyond rounding over that many iterations).
///
/// Compression root-finds try states where Newton cannot make progress. Under large stretch,
/// with the yarns jammed against each other, the line search accepts only steps of
/// `0.5⁴⁰ ≈ 1e-12`, at about 100 energy evaluations per iteration. Elsewhere, full steps leave
/// the residual at a rounding floor near 1e-8, above the tolerance. Such a solve, and its
/// restart with more pairs, used to run to the 200-iteration limit. On the babyredo rib fit
/// (`yarn-fit`'s settings, release, 2 cores) one Levenberg–Marquardt trial point took 378 s
/// this way, in 32 failed solves of 4–8 s each, and failed solves took about a third of the
/// fit's thread time.
///
/// Chosen on that fit's solves (the test evaluated after the fact on every run's histories):
///
/// | window | converging solves it would have stopped | iterations of the 213 failing solves |
/// |---|---|---|
/// | none | — | 42 500 |
/// | 10 | 4 of them, after 22–37 iterations | 16 901 |
/// | 20 | 1, at iteration 47 of 103 | 19 457 |
/// | 40 | none | 23 679 |
///
/// The two such runs whose histories were printed were climbing out of their flat stretch with
/// step lengths growing about 1.8× per iteration from 4e-15, behind a heavily shifted Hessian.
pub const STALL_ITERATIONS: usize = 40;

/// Settings of an equilibrium solve.
#[derive(Clone, Debug)]
pub struct EquilibriumSettings {
    /// Newton settings (tolerances on the Lagrangian gradient, J/m and J/rad).
    pub newton: NewtonSettings,
    /// The broad phase keeps pairs within `margin × cutoff`, so that pairs approaching during
    /// the solve are already in the pattern. Default 1.5.
    pub pair_margin: f64,
    /// How often the contact pairs may be rebuilt when the solution brings new pairs within
    /// the cutoff. Default 5.
    pub max_pair_updates: usize,
}

impl Default for EquilibriumSettings {
    fn default() -> Self {
        Self {
            // Exact Hessians (no per-stencil SPD projection; the solver regularizes when the
            // assembled Hessian is indefinite). On the stockinette tile, relaxing at rest takes
            // 11 Newton iterations this way and 76 with projection (sx = 0.3: 10 vs 98), to the
            // same Ψ; one release run took 0.23 s vs 1.9 s (not a benchmark).
            newton: NewtonSettings {
                gradient_abs_tol: 1e-9,
                gradient_rel_tol: 1e-9,
                max_iterations: 200,
                project_spd: false,
                stall_iterations: STALL_ITERATIONS,
                ..NewtonSettings::default()
            },
            pair_margin: 1.5,
            max_pair_updates: 5,
        }
    }
}

/// An equilibrium of a tile under a coarse deformation.
#[derive(Clone, Debug)]
pub struct Equilibrium {
    /// The coarse deformation.
    pub coarse: Coarse,
    /// DOFs: fluctuations (m) then edge twist angles (rad).
    pub dofs: Vec<f64>,
    /// Total energy E (J).
    pub energy: f64,
    /// Energy density Ψ = E/A (J/m²).
    pub density: f64,
    /// `∂Ψ/∂F₂` from the gathered stencil forces (N/m).
    pub stress: Matrix2<f64>,
    /// Contact pairs of the final problem.
    pub pairs: Vec<ContactPair>,
    /// Smallest centre-line distance of a contact pair (m), see
    /// [`PeriodicTile::closest_approach`].
    pub closest_approach: f64,
    /// Newton iterations summed over pair updates.
    pub iterations: usize,
}

/// How much wider the pair search is when a solve starts over (see [`solve_equilibrium`]).
const RESTART_MARGIN_FACTOR: f64 = 2.0;

/// Solves for the equilibrium of `tile` under `coarse`, starting from `start` (or the tile's
/// rest state), rebuilding the contact pairs until no pair outside the problem comes within
/// the cutoff. Errors if Newton fails or the pairs do not settle.
///
/// **Rotations.** The energy is objective, so the equilibria under `F₂ = R U` are those under
/// the stretch `U = √(F₂ᵀF₂)` with every fluctuation rotated by `R` (in-plane; twists
/// unchanged) and the stress `∂Ψ/∂F₂ = R ∂Ψ/∂U`. A flat solve therefore runs under `U` (the
/// start rotated by `Rᵀ`) and rotates the result, so the pulled-back displacements do not
/// depend on `R` — not even through which of several equilibria a solve reaches (a solve
/// under `R U` itself follows rotated iterates only up to rounding and the fixed search
/// directions of the negative-curvature steps, and reached a different equilibrium of the
/// real stockinette, Ψ 0.2 % lower, at `R = R(0.3)`, sx = 0.1, sa = 0.2, sy = −0.05).
///
/// **Pair updates.** The problem's pairs are those within `pair_margin × cutoff` of the
/// current state, united with every pair of earlier rounds (a pair never leaves during one
/// solve). A rebuild continues from the last equilibrium. Yarns that are not a pair of the
/// problem do not see each other (neither the energy nor the collision filter does), so a
/// round can move yarns into each other's contact range, or through each other, and the
/// Newton solve of that round or the next can stall. When a round fails, the solve starts
/// once more from `start`, with every pair found so far and those within
/// `2 × pair_margin × cutoff` of `start`, which the filter keeps apart from the beginning.
/// On the real stockinette under −40.6 % biaxial compression, continued from −37.5 %: the
/// first round (1714 pairs) stalls at residual 1.5 after 200 iterations, the restart (10 741
/// pairs) converges in 31.
pub fn solve_equilibrium(
    tile: &Tile,
    model: &YarnModel,
    coarse: Coarse,
    start: Option<&[f64]>,
    settings: &EquilibriumSettings,
) -> Result<Equilibrium, PeriodicError> {
    // Flat: solve under the stretch U of the polar decomposition F₂ = R U and rotate back
    // (see the documentation).
    if coarse.curvature.is_some() || !coarse.f.iter().all(|v| v.is_finite()) {
        return solve_under(tile, model, coarse, start, settings);
    }
    let u = sqrt_spd2(&(coarse.f.transpose() * coarse.f));
    let Some(r) = u.try_inverse().map(|u_inv| coarse.f * u_inv) else {
        return solve_under(tile, model, coarse, start, settings);
    };
    // Symmetric F₂ (every database sample, `F₂ = √I`): R = I up to rounding.
    if (r - Matrix2::identity()).amax() <= 1e-12 {
        return solve_under(tile, model, coarse, start, settings);
    }
    let rotate = |x: &mut [f64], r: &Matrix2<f64>| {
        for v in 0..x.len() / 4 {
            let w = r * Vector2::new(x[3 * v], x[3 * v + 1]);
            (x[3 * v], x[3 * v + 1]) = (w.x, w.y);
        }
    };
    let start = start.map(|s| {
        let mut s = s.to_vec();
        rotate(&mut s, &r.transpose());
        s
    });
    let mut eq = solve_under(tile, model, Coarse::in_plane(u), start.as_deref(), settings)?;
    rotate(&mut eq.dofs, &r);
    eq.stress = r * eq.stress;
    eq.coarse = coarse;
    Ok(eq)
}

/// [`solve_equilibrium`] under `coarse` itself.
fn solve_under(
    tile: &Tile,
    model: &YarnModel,
    coarse: Coarse,
    start: Option<&[f64]>,
    settings: &EquilibriumSettings,
) -> Result<Equilibrium, PeriodicError> {
    let start = start_dofs(tile, start)?;
    let settled = settle_pairs(
        tile,
        model,
        &start,
        settings,
        |_| coarse,
        |_, pairs| {
            let problem = PeriodicTile::new(tile, *model, coarse, pairs)?;
            let constraints = problem.constraints()?;
            Ok((problem, constraints))
        },
    )?;
    Ok(equilibrium_of(
        &settled.problem,
        settled.x,
        settled.energy,
        settled.iterations,
    ))
}

/// The [`Equilibrium`] of `problem` (its coarse map and pairs) at the solution `dofs`, with
/// the energy there and the Newton iterations that reached it.
pub(super) fn equilibrium_of(
    problem: &PeriodicTile,
    dofs: Vec<f64>,
    energy: f64,
    iterations: usize,
) -> Equilibrium {
    Equilibrium {
        coarse: problem.coarse,
        energy,
        density: energy / problem.area(),
        stress: problem.stress(&dofs),
        pairs: problem.pairs().to_vec(),
        closest_approach: problem.closest_approach(&dofs),
        dofs,
        iterations,
    }
}

/// `start`, or the tile's rest state, checked to hold the tile's `4 n` DOFs.
pub(super) fn start_dofs(tile: &Tile, start: Option<&[f64]>) -> Result<Vec<f64>, PeriodicError> {
    let start = match start {
        Some(s) => s.to_vec(),
        None => initial_dofs(tile)?,
    };
    if start.len() != 4 * tile.n_vertices() {
        return Err(PeriodicError::Invalid(format!(
            "start has {} DOFs, expected {}",
            start.len(),
            4 * tile.n_vertices()
        )));
    }
    Ok(start)
}

/// Where [`settle_pairs`] ended: the problem of the last round, its solution, the energy there
/// and the Newton iterations of every round.
pub(super) struct Settled<P> {
    pub problem: P,
    pub x: Vec<f64>,
    pub energy: f64,
    pub iterations: usize,
}

/// The pair-update rounds of [`solve_equilibrium`] (see there) for a tile problem whose DOFs
/// begin with the tile's fluctuations: `coarse(x)` is the coarse map at `x` (for the broad
/// phase), `build(x, pairs)` the problem with these pairs and its constraints. Starts from
/// `first`, and starts over from it once, with the wider pair search, when a round fails.
pub(super) fn settle_pairs<P: Problem>(
    tile: &Tile,
    model: &YarnModel,
    first: &[f64],
    settings: &EquilibriumSettings,
    coarse: impl Fn(&[f64]) -> Coarse,
    build: impl Fn(&[f64], Vec<ContactPair>) -> Result<(P, LinearConstraints), PeriodicError>,
) -> Result<Settled<P>, PeriodicError> {
    let mut x = first.to_vec();
    let mut iterations = 0;
    let mut known: Vec<ContactPair> = Vec::new();
    let mut restarted = false;
    for _ in 0..=settings.max_pair_updates {
        let margin = if restarted {
            RESTART_MARGIN_FACTOR * settings.pair_margin
        } else {
            settings.pair_margin
        };
        let near = PeriodicTile::find_pairs(tile, model, &coarse(&x), &x, margin)?;
        known = union(&known, &near);
        let (problem, constraints) = build(&x, known.clone())?;
        let report = match minimize_constrained(&problem, &mut x, &constraints, &settings.newton) {
            Ok(report) => report,
            Err(e) if !restarted => {
                // Start over with every pair seen so far (see the documentation).
                iterations += e.report().map_or(0, |r| r.iterations);
                restarted = true;
                x.copy_from_slice(first);
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        iterations += report.iterations;
        let needed = PeriodicTile::find_pairs(tile, model, &coarse(&x), &x, 1.0)?;
        if needed.iter().all(|p| known.binary_search(p).is_ok()) {
            return Ok(Settled {
                problem,
                energy: *report.energy_history.last().unwrap_or(&f64::NAN),
                x,
                iterations,
            });
        }
    }
    Err(PeriodicError::Invalid(format!(
        "contact pairs did not settle after {} rebuilds",
        settings.max_pair_updates
    )))
}

/// The sorted union of two sorted pair lists.
fn union(a: &[ContactPair], b: &[ContactPair]) -> Vec<ContactPair> {
    let mut out: Vec<ContactPair> = a.iter().chain(b).copied().collect();
    out.sort_unstable();
    out.dedup();
    out
}
