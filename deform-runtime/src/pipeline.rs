//! Loading a deformation setup from files: pattern (`.pyp`), database directory (MADYPG
//! `axes.txt` + `data.npy`) and the first mesh of an animation (OBJ with UVs).

use std::path::Path;

use yarn_pattern::madypg::Database;
use yarn_pattern::pyp::read_pyp;
use yarn_pattern::tile::Tile;

use crate::database::RuntimeDatabase;
use crate::deform::{DeformOptions, Deformer};
use crate::embed::{EmbedOptions, embed};
use crate::error::Result;
use crate::mesh::RestMesh;
use crate::obj::ObjMesh;
use crate::real::Real;

/// Setup options.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SetupOptions {
    /// UV units to metres (default 1: the mesh's UVs are in metres, as the CLI's default).
    pub uv_scale: f64,
    /// Precompute options.
    pub embed: EmbedOptions,
    /// Per-frame options.
    pub deform: DeformOptions,
}

impl Default for SetupOptions {
    /// UVs in metres and the default embedding and per-frame options. (A derived default
    /// would set `uv_scale` to 0, which [`build`] refuses.)
    fn default() -> Self {
        Self {
            uv_scale: 1.0,
            embed: EmbedOptions::default(),
            deform: DeformOptions::default(),
        }
    }
}

/// Builds a deformer from in-memory inputs.
pub fn build<T: Real>(
    tile: &Tile,
    db: &Database,
    mesh: &ObjMesh,
    options: &SetupOptions,
) -> Result<Deformer<T>> {
    let runtime = RuntimeDatabase::<T>::new(db, tile)?;
    let rest = RestMesh::new(mesh, options.uv_scale)?;
    let embedding = embed::<T>(&rest, tile, &options.embed)?;
    Deformer::new(rest, tile, embedding, runtime, options.deform)
}

/// Reads the pattern and the database and checks that they belong together.
pub fn load_pattern_and_database(pattern: &Path, database: &Path) -> Result<(Tile, Database)> {
    let tile = read_pyp(pattern)?.tile;
    let db = Database::read(database)?;
    // Validates vertex counts and values (the conversion is cheap compared to reading).
    RuntimeDatabase::<f32>::new(&db, &tile)?;
    Ok((tile, db))
}

/// Reads a `.pyp` pattern tile.
pub fn read_pattern(path: &Path) -> Result<Tile> {
    Ok(read_pyp(path)?.tile)
}
