//! ASCII PLY polylines with edges.
//!
//! Written exactly as:
//! ```text
//! ply
//! format ascii 1.0
//! comment <comment>
//! element vertex <vertices>
//! property float x
//! property float y
//! property float z
//! property int yarn
//! element edge <edges>
//! property int vertex1
//! property int vertex2
//! property int yarn
//! end_header
//! ```
//! then one line `x y z yarn` per vertex (`f32` values, m; `yarn` the curve index, −1 for a
//! vertex outside every curve) and one line
//! `v1 v2 yarn` per edge (0-based vertex indices; a closed curve with more than two vertices
//! has a closing edge from its last vertex to its first).

use std::io::Write;

use crate::polylines::Polylines;

/// Writes `lines` as ASCII PLY with a one-line `comment`.
pub fn write<T: Copy + Into<f64>>(
    w: &mut dyn Write,
    lines: &Polylines<'_, T>,
    comment: &str,
) -> std::io::Result<()> {
    write!(
        w,
        "ply\nformat ascii 1.0\ncomment {comment}\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nproperty int yarn\nelement edge {}\n\
         property int vertex1\nproperty int vertex2\nproperty int yarn\nend_header\n",
        lines.x.len(),
        lines.edge_count()
    )?;
    let mut yarn = vec![-1i64; lines.x.len()];
    for (c, (range, _)) in lines.curves().enumerate() {
        yarn[range].fill(c as i64);
    }
    for (k, c) in yarn.into_iter().enumerate() {
        let [x, y, z] = lines.point(k);
        writeln!(w, "{} {} {} {c}", x as f32, y as f32, z as f32)?;
    }
    for (c, path) in lines.edge_paths() {
        for e in path.windows(2) {
            writeln!(w, "{} {} {c}", e[0], e[1])?;
        }
    }
    Ok(())
}

/// The PLY text of `lines` (see [`write()`]).
pub fn to_string<T: Copy + Into<f64>>(lines: &Polylines<'_, T>, comment: &str) -> String {
    let mut out = Vec::new();
    write(&mut out, lines, comment).expect("writing to a Vec cannot fail");
    String::from_utf8(out).expect("PLY text is UTF-8")
}
