//! Relaxation of a tile to a stable rest state ([`relax`]) and its clearance check.

use super::PatternError;
use super::builder::{rebase, reset_rest_shape};
use crate::coarse::Coarse;
use crate::periodic::{
    Equilibrium, EquilibriumSettings, PeriodicTile, YarnModel, initial_dofs, solve_equilibrium,
};
use nalgebra::{Matrix2, Vector3};
use rod::contact::closest_points;
use std::time::Instant;
use yarn_pattern::tile::Tile;

/// Settings of [`relax`].
#[derive(Clone, Debug)]
pub struct RelaxSettings {
    /// Solve-and-reset rounds before the final solve (seed 002 §7.2). Default 2.
    pub rounds: usize,
    /// Bound on the relative change of each rest length from the guess's over all resets
    /// (seed 002 §7.2 uses 20 %). Default 0.2.
    pub max_rest_length_change: f64,
    /// The final solves are repeated until the largest vertex displacement of one is below
    /// this (m). Default 1e-10.
    pub settle_tolerance: f64,
    /// At most this many final solves. Default 6.
    pub max_settle_solves: usize,
    /// Settings of every equilibrium solve.
    pub equilibrium: EquilibriumSettings,
}

impl Default for RelaxSettings {
    fn default() -> Self {
        Self {
            rounds: 2,
            max_rest_length_change: 0.2,
            settle_tolerance: 1e-10,
            max_settle_solves: 6,
            equilibrium: EquilibriumSettings::default(),
        }
    }
}

/// What [`relax`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct RelaxReport {
    /// Newton iterations of each equilibrium solve (the rounds, then the final solves).
    pub iterations: Vec<usize>,
    /// Largest vertex displacement (m) of each solve.
    pub max_displacement: Vec<f64>,
    /// Energy density Ψ (J/m²) of the relaxed tile at zero strain.
    pub density: f64,
    /// Coarse stress `∂Ψ/∂F₂` (N/m) of the relaxed tile at zero strain.
    pub stress: Matrix2<f64>,
    /// Wall time of the whole relaxation (s).
    pub seconds: f64,
}

impl RelaxReport {
    /// Newton iterations summed over all solves.
    pub fn total_iterations(&self) -> usize {
        self.iterations.iter().sum()
    }
}

/// Relaxes `tile` at zero coarse strain; see the [module documentation](super) for the rounds
/// and what is reset. Returns the relaxed tile (its positions are an equilibrium of its rest
/// shape) and a report. Errors if a solve does not converge.
pub fn relax(
    tile: &Tile,
    model: &YarnModel,
    settings: &RelaxSettings,
) -> Result<(Tile, RelaxReport), PatternError> {
    let f = settings.max_rest_length_change;
    if !(f.is_finite() && (0.0..1.0).contains(&f)) {
        return Err(PatternError::Invalid(format!(
            "max_rest_length_change must be in [0, 1), found {f}"
        )));
    }
    if !(settings.settle_tolerance.is_finite() && settings.settle_tolerance > 0.0)
        || settings.max_settle_solves == 0
    {
        return Err(PatternError::Invalid(format!(
            "settle_tolerance must be positive and max_settle_solves at least 1, found {} and {}",
            settings.settle_tolerance, settings.max_settle_solves
        )));
    }
    let start = Instant::now();
    tile.validate()?;
    let l0 = tile.rest_lengths.clone();
    let mut current = tile.clone();
    let mut iterations = Vec::new();
    let mut max_displacement = Vec::new();
    let mut solve = |tile: &Tile| -> Result<(Tile, Equilibrium, f64), PatternError> {
        let eq = solve_equilibrium(tile, model, Coarse::identity(), None, &settings.equilibrium)?;
        let moved = (0..tile.n_vertices())
            .map(|v| Vector3::new(eq.dofs[3 * v], eq.dofs[3 * v + 1], eq.dofs[3 * v + 2]).norm())
            .fold(0.0, f64::max);
        iterations.push(eq.iterations);
        max_displacement.push(moved);
        Ok((rebase(tile, &eq.dofs)?, eq, moved))
    };
    for _ in 0..settings.rounds {
        current = solve(&current)?.0;
        reset_rest_shape(&mut current, Some((&l0, f)))?;
    }
    for _ in 0..settings.max_settle_solves {
        let (next, eq, moved) = solve(&current)?;
        current = next;
        if moved < settings.settle_tolerance {
            return Ok((
                current,
                RelaxReport {
                    iterations,
                    max_displacement,
                    density: eq.density,
                    stress: eq.stress,
                    seconds: start.elapsed().as_secs_f64(),
                },
            ));
        }
    }
    Err(PatternError::Invalid(format!(
        "the relaxed tile did not settle: the last of {} final solves moved it by {:.3e} m \
         (tolerance {:.3e} m)",
        settings.max_settle_solves,
        max_displacement.last().copied().unwrap_or(f64::NAN),
        settings.settle_tolerance
    )))
}

/// The closest pair of non-neighbouring yarn edges of a tile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clearance {
    /// Centre-line distance (m).
    pub distance: f64,
    /// First edge.
    pub a: usize,
    /// Second edge.
    pub b: usize,
    /// Period shift of edge `b`'s copy.
    pub image: [i32; 2],
}

/// The smallest centre-line distance between two edges of `tile` at rest, over the 3 × 3
/// periodic images, excluding pairs closer than `model.min_arc_separation` along one yarn
/// (neighbours). `None` if no such pair is closer than twice the contact cutoff.
pub fn min_clearance(tile: &Tile, model: &YarnModel) -> Result<Option<Clearance>, PatternError> {
    let x = initial_dofs(tile)?;
    let pairs = PeriodicTile::find_pairs(tile, model, &Coarse::identity(), &x, 2.0)?;
    let mut best: Option<Clearance> = None;
    for p in pairs {
        let (ea, eb) = (tile.edges[p.a], tile.edges[p.b]);
        let a0 = tile.positions[ea.v0];
        let a1 = tile.edge_end_shifted(p.a);
        let b0 = tile.positions[eb.v0] + tile.period_offset(p.image);
        let b1 = tile.edge_end_shifted(p.b) + tile.period_offset(p.image);
        let d = closest_points(&a0, &a1, &b0, &b1).2;
        if best.is_none_or(|c| d < c.distance) {
            best = Some(Clearance {
                distance: d,
                a: p.a,
                b: p.b,
                image: p.image,
            });
        }
    }
    Ok(best)
}
