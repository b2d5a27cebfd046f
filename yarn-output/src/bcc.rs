//! Cem Yuksel's binary curve collection (`.bcc`), the exchange format of knitted-garment yarn
//! models.
//!
//! One dialect, written exactly as (little-endian): a 64-byte header — bytes 0–2 `"BCC"`,
//! byte 3 `0x44` (4-byte floats and integers), bytes 4–5 the curve type ([`CurveType`]:
//! `"PL"` polyline or `"C0"` uniform Catmull-Rom through the points), byte 6 `3`
//! (dimensions), byte 7 the up axis (`1` = Y, `2` = Z; the coordinates are not rotated),
//! bytes 8–15 `u64` curve count, bytes 16–23 `u64` total point count, bytes 24–63 the info
//! text (at most 40 bytes, zero padded) — then per curve an `i32` point count `n` (negative
//! for a closed curve, `|n|` points) and `|n| × 3 f32` (x, y, z in metres).

use std::io::Write;

use crate::error::{OutputError, Result};
use crate::polylines::{Polylines, UpAxis};

/// The curve type of a `.bcc` file: how a reader interpolates the points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CurveType {
    /// `"PL"`: a polyline through the points.
    #[default]
    Polyline,
    /// `"C0"`: a uniform Catmull-Rom spline through the points (control points of a smooth
    /// curve).
    CatmullRom,
}

/// The header fields a caller chooses.
#[derive(Clone, Copy, Debug)]
pub struct BccHeader<'a> {
    /// Curve type (bytes 4–5).
    pub curve: CurveType,
    /// Up axis (byte 7).
    pub up: UpAxis,
    /// Info text (bytes 24–63), at most 40 bytes.
    pub info: &'a str,
}

/// Writes `lines` as `.bcc`; fails when the info text is longer than 40 bytes or a curve has
/// more than `i32::MAX` points.
pub fn write<T: Copy + Into<f64>>(
    w: &mut dyn Write,
    lines: &Polylines<'_, T>,
    header: &BccHeader<'_>,
) -> Result<std::io::Result<()>> {
    let info = header.info.as_bytes();
    if info.len() > 40 {
        return Err(OutputError::Option {
            name: "bcc info",
            message: format!("expected at most 40 bytes, found {}", info.len()),
        });
    }
    let counts = lines
        .curves()
        .map(|(r, closed)| {
            let n = i32::try_from(r.len()).map_err(|_| {
                OutputError::Invalid(format!("a curve of {} points does not fit .bcc", r.len()))
            })?;
            Ok(if closed { -n } else { n })
        })
        .collect::<Result<Vec<i32>>>()?;
    Ok(write_unchecked(w, lines, header, info, &counts))
}

fn write_unchecked<T: Copy + Into<f64>>(
    w: &mut dyn Write,
    lines: &Polylines<'_, T>,
    header: &BccHeader<'_>,
    info: &[u8],
    counts: &[i32],
) -> std::io::Result<()> {
    let mut head = [0u8; 64];
    head[0..3].copy_from_slice(b"BCC");
    head[3] = 0x44;
    head[4..6].copy_from_slice(match header.curve {
        CurveType::Polyline => b"PL",
        CurveType::CatmullRom => b"C0",
    });
    head[6] = 3;
    head[7] = match header.up {
        UpAxis::Y => 1,
        UpAxis::Z => 2,
    };
    let total: usize = lines.curves().map(|(r, _)| r.len()).sum();
    head[8..16].copy_from_slice(&(counts.len() as u64).to_le_bytes());
    head[16..24].copy_from_slice(&(total as u64).to_le_bytes());
    head[24..24 + info.len()].copy_from_slice(info);
    w.write_all(&head)?;
    for ((range, _), n) in lines.curves().zip(counts) {
        w.write_all(&n.to_le_bytes())?;
        for k in range {
            for c in lines.point(k) {
                w.write_all(&(c as f32).to_le_bytes())?;
            }
        }
    }
    Ok(())
}

/// The `.bcc` bytes of `lines` (see [`write()`]).
pub fn to_bytes<T: Copy + Into<f64>>(
    lines: &Polylines<'_, T>,
    header: &BccHeader<'_>,
) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    write(&mut out, lines, header)?.expect("writing to a Vec cannot fail");
    Ok(out)
}
