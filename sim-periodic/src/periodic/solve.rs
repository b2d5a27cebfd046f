//! Equilibrium solves: initial DOFs, settings, and the solve loop that rebuilds contact pairs.

use super::{ContactPair, PeriodicError, PeriodicTile, YarnModel};
use crate::coarse::Coarse;
use nalgebra::Matrix2;
use solver::{NewtonSettings, minimize_constrained};
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

/// Solves for the equilibrium of `tile` under `coarse`, starting from `start` (or the tile's
/// rest state), rebuilding the contact pairs until no pair outside the problem comes within
/// the cutoff. Errors if Newton fails or the pairs do not settle.
pub fn solve_equilibrium(
    tile: &Tile,
    model: &YarnModel,
    coarse: Coarse,
    start: Option<&[f64]>,
    settings: &EquilibriumSettings,
) -> Result<Equilibrium, PeriodicError> {
    let mut x = match start {
        Some(s) => s.to_vec(),
        None => initial_dofs(tile)?,
    };
    if x.len() != 4 * tile.n_vertices() {
        return Err(PeriodicError::Invalid(format!(
            "start has {} DOFs, expected {}",
            x.len(),
            4 * tile.n_vertices()
        )));
    }
    let mut iterations = 0;
    for _ in 0..=settings.max_pair_updates {
        let pairs = PeriodicTile::find_pairs(tile, model, &coarse, &x, settings.pair_margin)?;
        let problem = PeriodicTile::new(tile, *model, coarse, pairs)?;
        let constraints = problem.constraints()?;
        let report = minimize_constrained(&problem, &mut x, &constraints, &settings.newton)?;
        iterations += report.iterations;
        let needed = PeriodicTile::find_pairs(tile, model, &coarse, &x, 1.0)?;
        if needed
            .iter()
            .all(|p| problem.pairs().binary_search(p).is_ok())
        {
            let energy = *report.energy_history.last().unwrap_or(&f64::NAN);
            let approach = problem.closest_approach(&x);
            return Ok(Equilibrium {
                coarse,
                energy,
                density: energy / problem.area(),
                stress: problem.stress(&x),
                pairs: problem.pairs().to_vec(),
                closest_approach: approach,
                dofs: x,
                iterations,
            });
        }
    }
    Err(PeriodicError::Invalid(format!(
        "contact pairs did not settle after {} rebuilds",
        settings.max_pair_updates
    )))
}
