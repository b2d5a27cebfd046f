//! # yarn-output — writing yarn geometry, images and tables
//!
//! One place for everything the workbench writes (and the mesh and table files it reads), shared by the simulators, the deformer and
//! the figures. A leaf crate: it knows nothing about solvers, GPUs or any method.
//!
//! | module | contents |
//! |---|---|
//! | [`polylines`] | [`Polylines`]: yarn curves as coordinate arrays plus CSR curve offsets (a view), [`PolylineBuf`] (owned) |
//! | [`obj`], [`ply`], [`bcc`], [`usda`] | the four curve formats: Wavefront OBJ `l` elements, ASCII PLY with edges, Cem Yuksel's binary curve collection, USD ASCII `BasisCurves` |
//! | [`render`] | orthographic tube renderer (capsules, depth buffer, Lambert) and 8-bit RGB PNG images (`png` crate) |
//! | [`obj_mesh`] | the one OBJ triangle-mesh reader (single meshes and numbered sequences), for the deformer's meshes and the simulator's mesh obstacles |
//! | [`table`] | named `f64` columns with CSV read/write (`csv` crate), errors located by file and line |
//!
//! Every format is written exactly as its module documents. Closed curves are written by
//! repeating their first point (OBJ, PLY edges, USD) or with a negative point count (`.bcc`).

pub mod bcc;
pub mod error;
pub mod obj;
pub mod obj_mesh;
pub mod ply;
pub mod polylines;
pub mod render;
pub mod table;
pub mod usda;

pub use error::{OutputError, Result};
pub use polylines::{PolylineBuf, Polylines, UpAxis};

use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path`; an error names the file.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).map_err(|source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Creates `path` and runs `write` on a buffered writer to it; an error names the file.
pub fn write_with(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let io = |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::create(path).map_err(io)?;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, file);
    write(&mut w).and_then(|()| w.flush()).map_err(io)
}
