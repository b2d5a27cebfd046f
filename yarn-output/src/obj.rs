//! Wavefront OBJ polylines (and triangle meshes).
//!
//! Written exactly as: one `# <comment>` line; one `v x y z` line per vertex (m, `f64` in
//! Rust's shortest round-trip form); then one `l i₀ i₁ …` element per curve with at least two
//! vertices (1-based indices; a closed curve with more than two vertices repeats its first
//! index at the end). Triangle meshes ([`write_triangles`]) have `f i j k` elements instead;
//! [`crate::obj_mesh`] reads them back.

use std::io::Write;

use crate::polylines::Polylines;

/// Writes `lines` as OBJ text with a one-line `comment`.
pub fn write<T: Copy + Into<f64>>(
    w: &mut dyn Write,
    lines: &Polylines<'_, T>,
    comment: &str,
) -> std::io::Result<()> {
    let points = (0..lines.x.len()).map(|k| lines.point(k));
    let paths: Vec<Vec<usize>> = lines.edge_paths().map(|(_, p)| p).collect();
    write_indexed(w, points, &paths, comment)
}

/// Writes OBJ text of shared vertices `points` (m) and one `l` element per index path (0-based
/// indices into `points`; paths with fewer than two indices are skipped): the form for curves
/// that share vertices, e.g. yarns through common contact nodes.
pub fn write_indexed(
    w: &mut dyn Write,
    points: impl IntoIterator<Item = [f64; 3]>,
    paths: &[Vec<usize>],
    comment: &str,
) -> std::io::Result<()> {
    writeln!(w, "# {comment}")?;
    for [x, y, z] in points {
        writeln!(w, "v {x} {y} {z}")?;
    }
    for path in paths.iter().filter(|p| p.len() >= 2) {
        write!(w, "l")?;
        for k in path {
            write!(w, " {}", k + 1)?;
        }
        writeln!(w)?;
    }
    Ok(())
}

/// The OBJ text of `lines` (see [`write()`]).
pub fn to_string<T: Copy + Into<f64>>(lines: &Polylines<'_, T>, comment: &str) -> String {
    let mut out = Vec::new();
    write(&mut out, lines, comment).expect("writing to a Vec cannot fail");
    String::from_utf8(out).expect("OBJ text is UTF-8")
}

/// The OBJ text of shared vertices and index paths (see [`write_indexed`]).
pub fn indexed_to_string(
    points: impl IntoIterator<Item = [f64; 3]>,
    paths: &[Vec<usize>],
    comment: &str,
) -> String {
    let mut out = Vec::new();
    write_indexed(&mut out, points, paths, comment).expect("writing to a Vec cannot fail");
    String::from_utf8(out).expect("OBJ text is UTF-8")
}

/// Writes OBJ text of a triangle mesh: vertices `points` (m) and one `f i j k` element per
/// triangle (0-based indices into `points`, written 1-based).
pub fn write_triangles(
    w: &mut dyn Write,
    points: impl IntoIterator<Item = [f64; 3]>,
    triangles: &[[u32; 3]],
    comment: &str,
) -> std::io::Result<()> {
    writeln!(w, "# {comment}")?;
    for [x, y, z] in points {
        writeln!(w, "v {x} {y} {z}")?;
    }
    for [i, j, k] in triangles {
        writeln!(w, "f {} {} {}", i + 1, j + 1, k + 1)?;
    }
    Ok(())
}

/// The OBJ text of a triangle mesh (see [`write_triangles`]).
pub fn triangles_to_string(
    points: impl IntoIterator<Item = [f64; 3]>,
    triangles: &[[u32; 3]],
    comment: &str,
) -> String {
    let mut out = Vec::new();
    write_triangles(&mut out, points, triangles, comment).expect("writing to a Vec cannot fail");
    String::from_utf8(out).expect("OBJ text is UTF-8")
}
