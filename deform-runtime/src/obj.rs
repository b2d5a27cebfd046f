//! Wavefront OBJ input of the deformer: meshes with UVs and numbered sequences (mesh
//! animations), read by [`yarn_output::obj_mesh`] (the workbench's one OBJ reader). Every
//! face must reference a UV: the pattern is embedded in UV space, so a mesh without UVs is
//! an error naming the file and line. UVs are in metres, multiplied by a user scale.

use std::path::{Path, PathBuf};

use crate::error::{DeformError, Result};
pub use yarn_output::obj_mesh::ObjMesh;
use yarn_output::obj_mesh::{self as reader, Uv};

impl From<yarn_output::OutputError> for DeformError {
    fn from(e: yarn_output::OutputError) -> Self {
        match e {
            yarn_output::OutputError::Mesh {
                path,
                line,
                message,
            } => DeformError::Mesh {
                path,
                line,
                message,
            },
            yarn_output::OutputError::Io { path, source } => DeformError::Io { path, source },
            other => DeformError::Output(other),
        }
    }
}

/// Parses OBJ text with UVs on every face; `path` is used in error messages only.
pub fn parse_obj(text: &str, path: &Path) -> Result<ObjMesh> {
    Ok(reader::parse_obj(text, path, Uv::Required)?)
}

/// Reads an OBJ file with UVs on every face.
pub fn read_obj(path: impl AsRef<Path>) -> Result<ObjMesh> {
    Ok(reader::read_obj(path, Uv::Required)?)
}

/// Reads only the vertex positions of an animation frame into `out` (reusing its storage),
/// checking that the count matches `expected`. NaN/inf positions are accepted here; the
/// deformer sanitizes them per frame.
pub fn read_obj_positions(path: &Path, expected: usize, out: &mut Vec<[f64; 3]>) -> Result<()> {
    reader::read_obj_positions(path, out)?;
    if out.len() != expected {
        return Err(DeformError::FrameMismatch {
            path: path.to_path_buf(),
            message: format!(
                "expected {expected} vertices (as in the first frame), found {}",
                out.len()
            ),
        });
    }
    Ok(())
}

/// Expands a file pattern with `*` wildcards in its last component (e.g. `anim/cloth_*.obj`)
/// into the matching files, sorted by the numbers they contain (then by name)
/// ([`yarn_output::obj_mesh::expand_sequence`]).
pub fn expand_sequence(pattern: &str) -> Result<Vec<PathBuf>> {
    Ok(reader::expand_sequence(pattern)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_uvs_name_file_and_line() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\n\nf 1 2 3\n";
        let err = parse_obj(text, Path::new("nouv.obj"))
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("nouv.obj:5:"), "{err}");
        assert!(err.contains("texture coordinate"), "{err}");
    }
}
