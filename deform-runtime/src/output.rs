//! Writers for deformed yarn polylines: OBJ (`l` elements), ASCII PLY (vertices + edges) and
//! Cem Yuksel's binary curve collection `.bcc` (polylines, `PL`).
//!
//! Curves are given as structure-of-arrays coordinates plus CSR curve offsets; closed curves
//! repeat their first vertex in OBJ/PLY and are marked by a negative count in `.bcc`.

use std::io::Write;
use std::path::Path;

use crate::error::{DeformError, Result};
use crate::real::Real;

/// Polylines to write.
#[derive(Clone, Copy, Debug)]
pub struct Polylines<'a, T> {
    /// x coordinates (m).
    pub x: &'a [T],
    /// y coordinates (m).
    pub y: &'a [T],
    /// z coordinates (m).
    pub z: &'a [T],
    /// CSR offsets of the curves.
    pub curve_offsets: &'a [u32],
    /// Whether each curve is closed.
    pub closed: &'a [bool],
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> DeformError + '_ {
    move |source| DeformError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn create(path: &Path) -> Result<std::io::BufWriter<std::fs::File>> {
    Ok(std::io::BufWriter::with_capacity(
        1 << 20,
        std::fs::File::create(path).map_err(io(path))?,
    ))
}

impl<T: Real> Polylines<'_, T> {
    fn curves(&self) -> impl Iterator<Item = (std::ops::Range<usize>, bool)> + '_ {
        self.curve_offsets
            .windows(2)
            .zip(self.closed)
            .map(|(w, &c)| (w[0] as usize..w[1] as usize, c))
    }

    fn edge_count(&self) -> usize {
        self.curves()
            .map(|(r, c)| r.len().saturating_sub(1) + usize::from(c && r.len() > 2))
            .sum()
    }

    /// Writes a Wavefront OBJ with one `l` element per curve.
    pub fn write_obj(&self, path: &Path) -> Result<()> {
        let mut w = create(path)?;
        let write = |w: &mut std::io::BufWriter<std::fs::File>| -> std::io::Result<()> {
            writeln!(w, "# yarn polylines written by deform-runtime")?;
            for k in 0..self.x.len() {
                writeln!(
                    w,
                    "v {} {} {}",
                    self.x[k].to_f64(),
                    self.y[k].to_f64(),
                    self.z[k].to_f64()
                )?;
            }
            for (range, closed) in self.curves() {
                write!(w, "l")?;
                for k in range.clone() {
                    write!(w, " {}", k + 1)?;
                }
                if closed {
                    write!(w, " {}", range.start + 1)?;
                }
                writeln!(w)?;
            }
            w.flush()
        };
        write(&mut w).map_err(io(path))
    }

    /// Writes an ASCII PLY with `vertex` (x, y, z as float) and `edge` (vertex1, vertex2)
    /// elements.
    pub fn write_ply(&self, path: &Path) -> Result<()> {
        let mut w = create(path)?;
        let write = |w: &mut std::io::BufWriter<std::fs::File>| -> std::io::Result<()> {
            writeln!(
                w,
                "ply\nformat ascii 1.0\ncomment yarn polylines from deform-runtime"
            )?;
            writeln!(w, "element vertex {}", self.x.len())?;
            writeln!(w, "property float x\nproperty float y\nproperty float z")?;
            writeln!(w, "element edge {}", self.edge_count())?;
            writeln!(w, "property int vertex1\nproperty int vertex2\nend_header")?;
            for k in 0..self.x.len() {
                writeln!(
                    w,
                    "{} {} {}",
                    self.x[k].to_f64() as f32,
                    self.y[k].to_f64() as f32,
                    self.z[k].to_f64() as f32
                )?;
            }
            for (range, closed) in self.curves() {
                for k in range.start..range.end.saturating_sub(1) {
                    writeln!(w, "{} {}", k, k + 1)?;
                }
                if closed && range.len() > 2 {
                    writeln!(w, "{} {}", range.end - 1, range.start)?;
                }
            }
            w.flush()
        };
        write(&mut w).map_err(io(path))
    }

    /// Writes a `.bcc` file: 64-byte header (`BCC`, 0x44, `PL`, 3 dimensions, up axis Z,
    /// curve count, point count, info) then per curve `i32 n` (negative when closed) and
    /// `|n| × 3 f32`.
    pub fn write_bcc(&self, path: &Path) -> Result<()> {
        let mut w = create(path)?;
        let write = |w: &mut std::io::BufWriter<std::fs::File>| -> std::io::Result<()> {
            let mut header = [0u8; 64];
            header[0..3].copy_from_slice(b"BCC");
            header[3] = 0x44;
            header[4..6].copy_from_slice(b"PL");
            header[6] = 3;
            header[7] = 2;
            header[8..16].copy_from_slice(&(self.closed.len() as u64).to_le_bytes());
            header[16..24].copy_from_slice(&(self.x.len() as u64).to_le_bytes());
            let info = b"deform-runtime yarn polylines";
            header[24..24 + info.len()].copy_from_slice(info);
            w.write_all(&header)?;
            for (range, closed) in self.curves() {
                let n = range.len() as i32;
                w.write_all(&(if closed { -n } else { n }).to_le_bytes())?;
                for k in range {
                    for c in [self.x[k], self.y[k], self.z[k]] {
                        w.write_all(&(c.to_f64() as f32).to_le_bytes())?;
                    }
                }
            }
            w.flush()
        };
        write(&mut w).map_err(io(path))
    }
}
