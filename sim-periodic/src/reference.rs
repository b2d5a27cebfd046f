//! Our displacement database of a published tile, judged against the published table
//! (seed 004 §3; MADYPG's tables, relative to the tile's file geometry).
//!
//! A published table belongs to the `.pyp` shipped with it: its positions are the reference
//! solver's zero-strain equilibrium, ΔQ = 0 there, and every sample keeps the file's period
//! (see [`yarn_pattern::madypg`]). [`compare_with_published`] therefore
//!
//! 1. relaxes the file tile at zero strain under *our* model with the file's period and rest
//!    shape ([`relax_reference`]): how far this moves the tile is the first disagreement;
//! 2. generates our table on the published axes from that relaxed tile ([`generate`]);
//! 3. re-expresses our table relative to the file geometry
//!    ([`yarn_pattern::madypg::Database::offset_by`]) and compares the two with
//!    [`yarn_pattern::agreement`] (per-sample rigid translation removed, correlation and RMS).
//!
//! [`rest_state_forces`] splits the other side of step 1: the generalized force each energy
//! term of our model exerts on the file geometry, projected onto the constraint-free motions
//! (periodicity, no net translation, no sliding, no twist drift). At the reference solver's
//! equilibrium these forces cancel for its model; under ours, the term whose force is largest
//! is the one whose balance differs most.

use nalgebra::{DMatrix, DVector};
use solver::Assembler;
use std::time::Instant;
use yarn_pattern::agreement::Agreement;
use yarn_pattern::madypg::{Database, DatabaseError};
use yarn_pattern::tile::Tile;

use crate::coarse::Coarse;
use crate::database::{DatabaseSettings, GenerationError, generate, relax_reference};
use crate::periodic::{PeriodicError, PeriodicTile, YarnModel, initial_dofs};

/// Our table of a published tile and how it agrees with the published one.
#[derive(Clone, Debug)]
pub struct PublishedComparison {
    /// Our table on the published axes, relative to the file geometry (as the published one).
    pub ours: Database,
    /// Agreement with the published table.
    pub agreement: Agreement,
    /// RMS over vertices of how far our zero-strain relaxation moved the file's positions (m).
    pub relaxation_shift: f64,
    /// Samples our generation could not solve (filled from their continuation parent).
    pub unsolved: usize,
    /// Wall time of relaxation and generation (s).
    pub seconds: f64,
}

/// Generates our table of `file_tile` under `model` on the axes of `published` and compares
/// it with `published` (see the [module docs](self)). Unsolved samples are filled and counted
/// (`settings.fill_unsolved` is forced on), so one hard corner does not lose the comparison.
pub fn compare_with_published(
    file_tile: &Tile,
    published: &Database,
    model: &YarnModel,
    settings: &DatabaseSettings,
) -> Result<PublishedComparison, GenerationError> {
    let start = Instant::now();
    let expected = file_tile.n_vertices() * published.samples_per_vertex();
    if published.data.len() != expected {
        return Err(GenerationError::Database(DatabaseError::DataLength {
            expected,
            found: published.data.len(),
        }));
    }
    let (relaxed, _) = relax_reference(file_tile, model, &settings.equilibrium)?;
    let settings = DatabaseSettings {
        fill_unsolved: true,
        ..settings.clone()
    };
    let generated = generate(
        &relaxed,
        model,
        published.axes.clone(),
        &settings,
        None,
        &|_| {},
    )?;
    let offsets: Vec<[f64; 4]> = (0..file_tile.n_vertices())
        .map(|v| {
            let d = relaxed.positions[v] - file_tile.positions[v];
            [d.x, d.y, d.z, relaxed.twists[v] - file_tile.twists[v]]
        })
        .collect();
    let shift = offsets
        .iter()
        .map(|o| o[0] * o[0] + o[1] * o[1] + o[2] * o[2])
        .sum::<f64>()
        / offsets.len() as f64;
    let ours = generated
        .database
        .offset_by(&offsets)
        .expect("one offset per vertex");
    let agreement = ours
        .agreement(published)
        .expect("the same tile on the published axes");
    Ok(PublishedComparison {
        ours,
        agreement,
        relaxation_shift: shift.sqrt(),
        unsolved: generated.samples.iter().filter(|s| !s.solved).count(),
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The force of one energy term on a tile's geometry, projected onto the constraint-free
/// motions: Euclidean norms over the vertices' positions (N) and the edges' twists (N·m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TermForce {
    /// Norm of the positional part (N).
    pub position: f64,
    /// Norm of the twist part (N·m).
    pub twist: f64,
}

/// The projected force of every energy term of a model on a tile at zero strain, and of
/// their sum (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestStateForces {
    /// Stretch (seed 002 Eq. 5).
    pub stretch: TermForce,
    /// Bending with the tile's rest curvature (Eq. 6).
    pub bending: TermForce,
    /// Twist with the tile's rest twist.
    pub twist: TermForce,
    /// Both contact phases (Eq. 7), on the pairs within the solver's broad-phase margin.
    pub contact: TermForce,
    /// All terms together: zero at an equilibrium of this model.
    pub total: TermForce,
}

/// The projected per-term forces of `model` on `tile` as it is (its positions and twists, the
/// zero-strain state of a published tile), with contact pairs within `pair_margin` times the
/// model's cutoff (the solver's default is 1.5).
pub fn rest_state_forces(
    tile: &Tile,
    model: &YarnModel,
    pair_margin: f64,
) -> Result<RestStateForces, PeriodicError> {
    let x = initial_dofs(tile)?;
    let coarse = Coarse::identity();
    let pairs = PeriodicTile::find_pairs(tile, model, &coarse, &x, pair_margin)?;
    let full = PeriodicTile::new(tile, *model, coarse, pairs.clone())?;
    let constraints = full.constraints()?;
    let mut c = DMatrix::<f64>::zeros(constraints.n_constraints(), x.len());
    for &(row, col, value) in constraints.triplets() {
        c[(row, col)] += value;
    }
    let cct_inverse = (&c * c.transpose())
        .try_inverse()
        .ok_or_else(|| PeriodicError::Invalid("dependent constraints".into()))?;
    let n_positions = 3 * tile.n_vertices();
    let project = |g: &[f64]| -> TermForce {
        let g = DVector::from_column_slice(g);
        let free = &g - c.transpose() * (&cct_inverse * (&c * &g));
        TermForce {
            position: free.rows(0, n_positions).norm(),
            twist: free.rows(n_positions, free.len() - n_positions).norm(),
        }
    };
    let force = |p: &PeriodicTile| -> Result<TermForce, PeriodicError> {
        let mut assembler = Assembler::new(p)?;
        Ok(project(assembler.gradient(p, &x)?.1))
    };
    let gradient = |m: YarnModel| force(&PeriodicTile::new(tile, m, coarse, pairs.clone())?);
    let only = |keep: &dyn Fn(&mut YarnModel, &YarnModel)| {
        let mut m = *model;
        m.stretch = rod::stretch::StretchLaw::Linear { k: 0.0 };
        m.bending = 0.0;
        m.twist = 0.0;
        for phase in &mut m.contact {
            phase.stiffness = 0.0;
        }
        keep(&mut m, model);
        m
    };
    Ok(RestStateForces {
        stretch: gradient(only(&|m, o| m.stretch = o.stretch))?,
        bending: gradient(only(&|m, o| m.bending = o.bending))?,
        twist: gradient(only(&|m, o| m.twist = o.twist))?,
        contact: gradient(only(&|m, o| m.contact = o.contact))?,
        total: force(&full)?,
    })
}
