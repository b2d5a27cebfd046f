//! Wavefront OBJ triangle-mesh input: single meshes and numbered sequences (mesh
//! animations), for the deformer's meshes (`deform-runtime`) and the simulator's mesh
//! obstacles (`sim-persistent`). The one OBJ reader of the workbench (the writer is
//! [`crate::obj`]).
//!
//! Read: `v x y z`, `vt u v` and `f` with `v`, `v/vt`, `v//vn` or `v/vt/vn` corners; polygons
//! with more than three corners are fan-triangulated (quads become two triangles). Negative
//! (relative) indices are supported. Other statements (`vn`, `o`, `g`, `s`, `usemtl`,
//! `mtllib`, ...) are ignored. With [`Uv::Required`] every face corner must reference a UV (the
//! deformer embeds its pattern in UV space); with [`Uv::Ignored`] UVs are not read. Errors name
//! the file and line and say what was expected.

use std::path::{Path, PathBuf};

use crate::error::{OutputError, Result};

/// Whether faces must carry texture coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Uv {
    /// Every face corner is `v/vt` or `v/vt/vn`; [`ObjMesh::tri_uvs`] parallels the triangles.
    Required,
    /// Texture coordinates are skipped; [`ObjMesh::uvs`] and [`ObjMesh::tri_uvs`] stay empty.
    Ignored,
}

/// A triangle mesh as read from an OBJ file.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjMesh {
    /// Vertex positions (m).
    pub positions: Vec<[f64; 3]>,
    /// Texture coordinates (m, before scaling).
    pub uvs: Vec<[f64; 2]>,
    /// Triangles as position indices (0-based).
    pub tri_positions: Vec<[u32; 3]>,
    /// Triangles as UV indices (0-based); empty with [`Uv::Ignored`].
    pub tri_uvs: Vec<[u32; 3]>,
}

fn mesh_error(path: &Path, line: usize, message: impl Into<String>) -> OutputError {
    OutputError::Mesh {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

fn parse_floats<const N: usize>(
    tokens: &mut std::str::SplitWhitespace<'_>,
    path: &Path,
    line: usize,
    what: &str,
) -> Result<[f64; N]> {
    let mut out = [0.0f64; N];
    for (k, slot) in out.iter_mut().enumerate() {
        let token = tokens.next().ok_or_else(|| {
            mesh_error(
                path,
                line,
                format!("expected {N} numbers after `{what}`, found {k}"),
            )
        })?;
        *slot = token.parse().map_err(|_| {
            mesh_error(
                path,
                line,
                format!("expected a number after `{what}`, found {token:?}"),
            )
        })?;
        if !slot.is_finite() && what == "vt" {
            return Err(mesh_error(
                path,
                line,
                format!("expected a finite texture coordinate, found {token:?}"),
            ));
        }
    }
    Ok(out)
}

fn resolve(index: i64, count: usize, path: &Path, line: usize, what: &str) -> Result<u32> {
    let resolved = if index > 0 {
        index - 1
    } else if index < 0 {
        count as i64 + index
    } else {
        -1
    };
    if resolved < 0 || resolved >= count as i64 {
        return Err(mesh_error(
            path,
            line,
            format!(
                "expected a {what} index in 1..={count} (or a negative relative index), found {index}"
            ),
        ));
    }
    Ok(resolved as u32)
}

/// Parses OBJ text; `path` is used in error messages only.
pub fn parse_obj(text: &str, path: &Path, uv: Uv) -> Result<ObjMesh> {
    let mut mesh = ObjMesh {
        positions: Vec::new(),
        uvs: Vec::new(),
        tri_positions: Vec::new(),
        tri_uvs: Vec::new(),
    };
    let mut corners: Vec<(u32, u32)> = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let content = raw.split('#').next().unwrap_or("");
        let mut tokens = content.split_whitespace();
        match tokens.next() {
            Some("v") => {
                let p = parse_floats::<3>(&mut tokens, path, line, "v")?;
                if !p.iter().all(|x| x.is_finite()) {
                    return Err(mesh_error(
                        path,
                        line,
                        format!("`v`: expected finite coordinates, found {p:?}"),
                    ));
                }
                mesh.positions.push(p);
            }
            Some("vt") if uv == Uv::Required => {
                let t = parse_floats::<2>(&mut tokens, path, line, "vt")?;
                mesh.uvs.push(t);
            }
            Some("f") => {
                corners.clear();
                for token in tokens {
                    let mut parts = token.split('/');
                    let v = parts.next().unwrap_or("");
                    let vt = parts.next().unwrap_or("");
                    let parse = |s: &str, what: &str| -> Result<i64> {
                        s.parse::<i64>().map_err(|_| {
                            mesh_error(
                                path,
                                line,
                                format!(
                                    "expected a face corner `v/vt` with a {what} index, found {token:?}"
                                ),
                            )
                        })
                    };
                    if uv == Uv::Ignored {
                        let vi =
                            resolve(parse(v, "vertex")?, mesh.positions.len(), path, line, "v")?;
                        corners.push((vi, 0));
                        continue;
                    }
                    if vt.is_empty() {
                        return Err(mesh_error(
                            path,
                            line,
                            format!(
                                "expected a face corner `v/vt` with a texture coordinate (the pattern is embedded in UV space), found {token:?}"
                            ),
                        ));
                    }
                    let vi = resolve(parse(v, "vertex")?, mesh.positions.len(), path, line, "v")?;
                    let ti = resolve(parse(vt, "texture")?, mesh.uvs.len(), path, line, "vt")?;
                    corners.push((vi, ti));
                }
                if corners.len() < 3 {
                    return Err(mesh_error(
                        path,
                        line,
                        format!("expected at least 3 face corners, found {}", corners.len()),
                    ));
                }
                for j in 1..corners.len() - 1 {
                    let c = [corners[0], corners[j], corners[j + 1]];
                    mesh.tri_positions.push(c.map(|x| x.0));
                    if uv == Uv::Required {
                        mesh.tri_uvs.push(c.map(|x| x.1));
                    }
                }
            }
            _ => {}
        }
    }
    if mesh.tri_positions.is_empty() {
        return Err(mesh_error(
            path,
            0,
            "expected at least one face (`f` statement), found none",
        ));
    }
    Ok(mesh)
}

/// Reads an OBJ file.
pub fn read_obj(path: impl AsRef<Path>, uv: Uv) -> Result<ObjMesh> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_obj(&text, path, uv)
}

/// Reads only the vertex positions of an animation frame into `out` (reusing its storage).
/// Non-finite positions are accepted (callers decide); the caller checks the count against
/// its first frame.
pub fn read_obj_positions(path: &Path, out: &mut Vec<[f64; 3]>) -> Result<()> {
    let text = std::fs::read_to_string(path).map_err(|source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_obj_positions(&text, path, out)
}

/// [`read_obj_positions`] on the text of `path`.
pub fn parse_obj_positions(text: &str, path: &Path, out: &mut Vec<[f64; 3]>) -> Result<()> {
    out.clear();
    for (k, raw) in text.lines().enumerate() {
        let content = raw.split('#').next().unwrap_or("");
        let mut tokens = content.split_whitespace();
        if tokens.next() == Some("v") {
            out.push(parse_floats::<3>(&mut tokens, path, k + 1, "v")?);
        }
    }
    Ok(())
}

/// Expands a file pattern with `*` wildcards in its last component (e.g. `anim/cloth_*.obj`)
/// into the matching files, sorted by the numbers they contain (then by name), so that
/// `f_2.obj` comes before `f_10.obj`. A pattern without `*` names one file.
pub fn expand_sequence(pattern: &str) -> Result<Vec<PathBuf>> {
    let path = Path::new(pattern);
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or(pattern)
        .to_string();
    if !name.contains('*') {
        return Ok(vec![path.to_path_buf()]);
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let entries = std::fs::read_dir(&dir).map_err(|source| OutputError::Io {
        path: dir.clone(),
        source,
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_file())
        .filter_map(|e| {
            let n = e.file_name().to_str()?.to_string();
            wildcard_match(&name, &n).then(|| e.path())
        })
        .collect();
    files.sort_by_key(|p| {
        let n = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
        (numbers_in(n), n.to_string())
    });
    if files.is_empty() {
        return Err(OutputError::Io {
            path: PathBuf::from(pattern),
            source: std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "expected at least one file matching the pattern, found none",
            ),
        });
    }
    Ok(files)
}

fn numbers_in(name: &str) -> Vec<u64> {
    let mut out = Vec::new();
    let mut current: Option<u64> = None;
    for c in name.chars() {
        if let Some(d) = c.to_digit(10) {
            current = Some(
                current
                    .unwrap_or(0)
                    .saturating_mul(10)
                    .saturating_add(d.into()),
            );
        } else if let Some(n) = current.take() {
            out.push(n);
        }
    }
    out.extend(current);
    out
}

/// Whether `name` matches `pattern`, where `*` matches any run of characters.
pub fn wildcard_match(pattern: &str, name: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    if parts.len() == 1 {
        return pattern == name;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !name.starts_with(first) || name.len() < first.len() + last.len() || !name.ends_with(last) {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for part in &parts[1..parts.len() - 1] {
        match rest.find(part) {
            Some(i) => rest = &rest[i + part.len()..],
            None => return false,
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quads_are_triangulated_and_indices_resolved() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 -1/-1\n";
        let m = parse_obj(text, Path::new("q.obj"), Uv::Required).unwrap();
        assert_eq!(m.tri_positions, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.tri_uvs, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn missing_uvs_name_file_and_line() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\n\nf 1 2 3\n";
        let err = parse_obj(text, Path::new("nouv.obj"), Uv::Required)
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("nouv.obj:5:"), "{err}");
        assert!(err.contains("texture coordinate"), "{err}");
    }

    #[test]
    fn bad_numbers_and_indices_are_errors() {
        let err = parse_obj("v 0 x 0\n", Path::new("a.obj"), Uv::Required)
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("a.obj:1:") && err.contains("\"x\""),
            "{err}"
        );
        let err = parse_obj(
            "v 0 0 0\nvt 0 0\nf 1/1 2/1 1/1\n",
            Path::new("b.obj"),
            Uv::Required,
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.starts_with("b.obj:3:") && err.contains("found 2"),
            "{err}"
        );
    }

    #[test]
    fn meshes_without_uvs_read_when_uvs_are_ignored() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1 3 4\n";
        let m = parse_obj(text, Path::new("n.obj"), Uv::Ignored).unwrap();
        assert_eq!(m.tri_positions, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(m.uvs.is_empty() && m.tri_uvs.is_empty());
        let err = parse_obj("v 0 0 0\nf 1 2 1\n", Path::new("c.obj"), Uv::Ignored)
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("c.obj:2:") && err.contains("found 2"),
            "{err}"
        );
    }

    #[test]
    fn wildcards_and_numeric_order() {
        assert!(wildcard_match("anim_*.obj", "anim_0010.obj"));
        assert!(!wildcard_match("anim_*.obj", "anim_0010.ply"));
        assert!(wildcard_match("a*b*c", "axxbyyc"));
        assert!(!wildcard_match("a*b*c", "axxc"));
        assert!(numbers_in("f_2.obj") < numbers_in("f_10.obj"));
    }
}
