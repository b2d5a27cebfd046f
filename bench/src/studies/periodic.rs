//! Shared set-up of the periodic-tile figures: the tiles (the real stockinette and relaxed
//! procedural patterns), each relaxed to a stress-free period, and their uniaxial curves.

use anyhow::Context;
use sim_periodic::curves::{CurvePoint, CurveSettings, uniaxial_curve};
use sim_periodic::database::relax_period;
use sim_periodic::patterns::{Pattern, RelaxSettings, relax};
use sim_periodic::periodic::{EquilibriumSettings, YarnModel};
use yarn_pattern::direction::Direction;
use yarn_pattern::tile::Tile;

/// The real stockinette tile shipped with the tests (MADYPG, see its licence).
pub fn real_stockinette() -> anyhow::Result<Tile> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    );
    Ok(yarn_pattern::pyp::read_pyp(path)
        .with_context(|| format!("reading {path}"))?
        .tile)
}

/// A relaxed procedural pattern of yarn radius `radius` at `resolution` (vertices per knit
/// loop / per weave crossing; `None` for the library default).
pub fn pattern_tile(
    pattern: Pattern,
    radius: f64,
    resolution: Option<usize>,
) -> anyhow::Result<Tile> {
    let mut params = pattern.default_params(radius);
    if let Some(r) = resolution {
        params.resolution = r;
    }
    let guess = pattern.generate(&params)?;
    let model = YarnModel::default_for_radius(radius);
    Ok(relax(&guess, &model, &RelaxSettings::default())?.0)
}

/// `tile` relaxed at zero strain with its period relaxed to zero normal stress (1e-6 N/m).
pub fn stress_free(
    tile: &Tile,
    model: &YarnModel,
    settings: &EquilibriumSettings,
) -> anyhow::Result<Tile> {
    Ok(relax_period(tile, model, settings, 1e-6)?.0)
}

/// The uniaxial curve of a stress-free tile.
pub fn curve(
    tile: &Tile,
    model: &YarnModel,
    direction: Direction,
    stretches: &[f64],
    settings: &CurveSettings,
) -> anyhow::Result<Vec<CurvePoint>> {
    Ok(uniaxial_curve(tile, model, direction, stretches, settings)?)
}
