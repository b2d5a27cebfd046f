//! The tube renderer and PNG encoder: PNG structure (checked with independent CRC-32 and
//! Adler-32 implementations and a stored-block inflater), tube width in pixels, depth ordering,
//! empty input, non-finite vertices, option errors, and a real deformed pattern.

mod common;

use common::*;
use deform_runtime::output::Polylines;
use deform_runtime::render::{Camera, Framing, Image, RenderOptions, Rendering, render_tubes};
use deform_runtime::{DeformError, DeformOptions, synthetic};

/// Bitwise CRC-32 (no table), independent of the crate's.
fn crc32_bitwise(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 == 1 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// A decoded PNG: size and RGB pixels.
struct Decoded {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
    chunks: Vec<[u8; 4]>,
}

/// Decodes the subset of PNG the encoder writes, checking every structural field on the way.
fn decode_png(png: &[u8]) -> Decoded {
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "signature");
    let mut at = 8;
    let mut chunks = Vec::new();
    let (mut width, mut height) = (0, 0);
    let mut idat = Vec::new();
    while at < png.len() {
        let len = u32::from_be_bytes(png[at..at + 4].try_into().unwrap()) as usize;
        let kind: [u8; 4] = png[at + 4..at + 8].try_into().unwrap();
        let data = &png[at + 8..at + 8 + len];
        let crc = u32::from_be_bytes(png[at + 8 + len..at + 12 + len].try_into().unwrap());
        assert_eq!(
            crc,
            crc32_bitwise(&png[at + 4..at + 8 + len]),
            "CRC of chunk {}",
            String::from_utf8_lossy(&kind)
        );
        match &kind {
            b"IHDR" => {
                assert_eq!(len, 13);
                width = u32::from_be_bytes(data[0..4].try_into().unwrap());
                height = u32::from_be_bytes(data[4..8].try_into().unwrap());
                assert_eq!(&data[8..13], &[8, 2, 0, 0, 0], "8-bit RGB, no interlace");
            }
            b"IDAT" => idat.extend_from_slice(data),
            b"IEND" => assert_eq!(len, 0),
            other => panic!("unexpected chunk {other:?}"),
        }
        chunks.push(kind);
        at += 12 + len;
    }
    assert_eq!(at, png.len(), "trailing bytes");
    assert_eq!(chunks.first(), Some(b"IHDR"));
    assert_eq!(chunks.last(), Some(b"IEND"));
    // zlib header, then stored blocks, then Adler-32.
    assert_eq!(
        (u16::from(idat[0]) << 8 | u16::from(idat[1])) % 31,
        0,
        "FCHECK"
    );
    assert_eq!(idat[0] & 0x0F, 8, "deflate");
    let mut raw = Vec::new();
    let mut p = 2;
    loop {
        let header = idat[p];
        assert_eq!(header & 0b110, 0, "stored block");
        let len = u16::from_le_bytes([idat[p + 1], idat[p + 2]]);
        let nlen = u16::from_le_bytes([idat[p + 3], idat[p + 4]]);
        assert_eq!(len, !nlen, "LEN/NLEN");
        raw.extend_from_slice(&idat[p + 5..p + 5 + len as usize]);
        p += 5 + len as usize;
        if header & 1 == 1 {
            break;
        }
    }
    let adler = u32::from_be_bytes(idat[p..p + 4].try_into().unwrap());
    assert_eq!(p + 4, idat.len());
    let (mut a, mut b) = (1u64, 0u64);
    for &x in &raw {
        a = (a + u64::from(x)) % 65521;
        b = (b + a) % 65521;
    }
    assert_eq!(adler, ((b << 16) | a) as u32, "Adler-32");
    let row = 1 + 3 * width as usize;
    assert_eq!(raw.len(), row * height as usize, "scanline bytes");
    let mut rgb = Vec::new();
    for line in raw.chunks(row) {
        assert_eq!(line[0], 0, "filter type");
        rgb.extend_from_slice(&line[1..]);
    }
    Decoded {
        width,
        height,
        rgb,
        chunks,
    }
}

/// Polylines from (x, y, z) points, one curve per list.
struct Curves {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    offsets: Vec<u32>,
    closed: Vec<bool>,
}

impl Curves {
    fn new(curves: &[&[[f64; 3]]]) -> Self {
        let mut c = Curves {
            x: vec![],
            y: vec![],
            z: vec![],
            offsets: vec![0],
            closed: vec![],
        };
        for curve in curves {
            for p in *curve {
                c.x.push(p[0]);
                c.y.push(p[1]);
                c.z.push(p[2]);
            }
            c.offsets.push(c.x.len() as u32);
            c.closed.push(false);
        }
        c
    }

    fn lines(&self) -> Polylines<'_, f64> {
        Polylines {
            x: &self.x,
            y: &self.y,
            z: &self.z,
            curve_offsets: &self.offsets,
            closed: &self.closed,
        }
    }
}

fn is_background(image: &Image, x: u32, y: u32) -> bool {
    image.pixel(x, y) == [255, 255, 255]
}

#[test]
fn png_decodes_structurally_and_round_trips_the_pixels() {
    // Large enough for several stored blocks (3 · 200 · 150 + 150 > 65535 bytes).
    let c = Curves::new(&[&[[-1.0, -0.5, 0.0], [1.0, 0.5, 0.2]], &[[0.0, 0.7, 0.0]]]);
    let r = render_tubes(&c.lines(), &RenderOptions::new(200, 150, 0.1)).unwrap();
    let png = r.image.to_png();
    let d = decode_png(&png);
    assert_eq!((d.width, d.height), (200, 150));
    assert_eq!(d.chunks, [*b"IHDR", *b"IDAT", *b"IEND"]);
    assert_eq!(d.rgb, r.image.rgb);
    assert_eq!(r.segments, 2, "one segment and one single-vertex sphere");
    // Flipping one byte breaks the chunk's CRC (the decoder's check is not vacuous).
    let mut broken = png.clone();
    broken[8 + 8 + 5] ^= 1; // inside IHDR's data (length 4, type 4, data 13, CRC 4)
    let stored = u32::from_be_bytes(broken[8 + 21..8 + 25].try_into().unwrap());
    assert_eq!(stored, crc32_bitwise(&png[8 + 4..8 + 21]));
    assert_ne!(stored, crc32_bitwise(&broken[8 + 4..8 + 21]));
    // A 1 × 1 image is valid too.
    let d = decode_png(&deform_runtime::render::encode_png(1, 1, &[1, 2, 3]));
    assert_eq!((d.width, d.height, d.rgb), (1, 1, vec![1, 2, 3]));
}

/// Covered pixels in column `x` and row `y`.
fn band(r: &Rendering, x: u32, y: u32) -> (usize, usize) {
    let img = &r.image;
    let col = (0..img.height)
        .filter(|&j| !is_background(img, x, j))
        .count();
    let row = (0..img.width)
        .filter(|&i| !is_background(img, i, y))
        .count();
    (col, row)
}

#[test]
fn straight_tube_covers_a_band_two_radii_wide() {
    let radius = 0.05;
    let c = Curves::new(&[&[[-1.0, 0.0, 0.3], [1.0, 0.0, 0.3]]]);
    // Fixed framing, off the pixel grid: 100 px/m, so the band is 2R = 10 px wide and
    // 2 + 2R = 2.1 m = 210 px long.
    for offset in [0.0, 0.0037, -0.0121] {
        let options = RenderOptions {
            framing: Framing::Fixed {
                center: [0.0, offset],
                pixels_per_metre: 100.0,
            },
            ..RenderOptions::new(300, 100, radius)
        };
        let r = render_tubes(&c.lines(), &options).unwrap();
        let (width, length) = band(&r, 150, 50);
        eprintln!("offset {offset}: band {width} px wide (2R = 10 px), {length} px long (210)");
        assert!(width.abs_diff(10) <= 1, "band width {width} px");
        assert!(length.abs_diff(210) <= 1, "band length {length} px");
    }
    // Auto framing of a tilted tube viewed obliquely: the silhouette of a capsule under an
    // orthographic camera is 2R wide whatever the tilt.
    let c = Curves::new(&[&[[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]);
    let options = RenderOptions {
        camera: Camera {
            direction: [0.0, 1.0, -1.0],
            up: [0.0, 1.0, 0.0],
        },
        ..RenderOptions::new(64, 256, radius)
    };
    let r = render_tubes(&c.lines(), &options).unwrap();
    let Framing::Fixed {
        pixels_per_metre, ..
    } = r.framing
    else {
        panic!("framing is returned fixed")
    };
    let expected = 2.0 * radius * pixels_per_metre;
    let (_, width) = band(&r, 32, 128);
    eprintln!("oblique: {width} px wide, 2R = {expected:.2} px");
    assert!(
        (width as f64 - expected).abs() <= 1.0,
        "{width} vs {expected}"
    );
    // Auto framing leaves the margin free: the first and last rows are background.
    assert!((0..64).all(|i| is_background(&r.image, i, 0) && is_background(&r.image, i, 255)));
    // Shading: the centre line faces the viewer and is lit, the rim is darker but above the
    // ambient level of the base colour.
    let base = r.image.pixel(32, 128);
    let rim = (0..64)
        .find(|&i| !is_background(&r.image, i, 128))
        .map(|i| r.image.pixel(i, 128))
        .unwrap();
    let sum = |c: [u8; 3]| c.iter().map(|&v| u32::from(v)).sum::<u32>();
    assert!(sum(base) > sum(rim), "{base:?} vs rim {rim:?}");
    let palette = options.palette[0];
    for d in 0..3 {
        assert!(u32::from(base[d]) <= u32::from(palette[d]));
        assert!(f64::from(rim[d]) >= options.ambient * f64::from(palette[d]) - 1.0);
    }
}

#[test]
fn near_tube_hides_far_tube_whatever_the_drawing_order() {
    let red = [220, 20, 20];
    let blue = [20, 20, 220];
    let along_x = |z: f64| [[-1.0, 0.0, z], [1.0, 0.0, z]];
    let along_y = |z: f64| [[0.0, -1.0, z], [0.0, 1.0, z]];
    let options = RenderOptions {
        palette: vec![red, blue],
        ..RenderOptions::new(101, 101, 0.1)
    };
    // The camera looks along −z: larger z is nearer.
    for (z_red, z_blue, near) in [(0.0, 0.5, "blue"), (0.5, 0.0, "red")] {
        let a = along_x(z_red);
        let b = along_y(z_blue);
        for (curves, colours) in [
            ([&a[..], &b[..]], [red, blue]),
            ([&b[..], &a[..]], [blue, red]),
        ] {
            let c = Curves::new(&curves);
            let r = render_tubes(
                &c.lines(),
                &RenderOptions {
                    palette: colours.to_vec(),
                    ..options.clone()
                },
            )
            .unwrap();
            let p = r.image.pixel(50, 50);
            let seen = if p[2] > p[0] { "blue" } else { "red" };
            assert_eq!(seen, near, "crossing pixel {p:?}");
            // Away from the crossing both tubes are visible.
            let left = r.image.pixel(10, 50);
            let top = r.image.pixel(50, 10);
            assert!(left[0] > left[2] && top[2] > top[0], "{left:?} {top:?}");
        }
    }
}

#[test]
fn empty_input_gives_a_blank_image() {
    let empty = Curves::new(&[]);
    for offsets in [vec![], vec![0]] {
        let lines = Polylines {
            curve_offsets: &offsets,
            closed: &[],
            ..empty.lines()
        };
        let r = render_tubes(&lines, &RenderOptions::new(40, 30, 0.01)).unwrap();
        assert_eq!(r.segments, 0);
        assert!(r.image.rgb.iter().all(|&v| v == 255));
        assert_eq!(decode_png(&r.image.to_png()).rgb, r.image.rgb);
    }
    // All vertices non-finite: blank too, and counted.
    let c = Curves::new(&[&[[f64::NAN, 0.0, 0.0], [0.0, f64::INFINITY, 0.0]]]);
    let r = render_tubes(&c.lines(), &RenderOptions::new(40, 30, 0.01)).unwrap();
    assert_eq!((r.segments, r.skipped_vertices), (0, 2));
    assert!(r.image.rgb.iter().all(|&v| v == 255));
}

#[test]
fn nonfinite_vertices_are_skipped() {
    let nan = f64::NAN;
    let curve = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [2.0, nan, 0.0],
        [3.0, 0.0, 0.0],
        [4.0, 0.0, f64::NEG_INFINITY],
        [5.0, 0.0, 0.0],
        [6.0, 0.0, 0.0],
    ];
    let c = Curves::new(&[&curve]);
    let options = RenderOptions {
        framing: Framing::Fixed {
            center: [3.0, 0.0],
            pixels_per_metre: 20.0,
        },
        ..RenderOptions::new(160, 20, 0.1)
    };
    let r = render_tubes(&c.lines(), &options).unwrap();
    assert_eq!(r.skipped_vertices, 2);
    assert_eq!(r.segments, 2, "0–1 and 5–6 only");
    // Pixel column of world x: 80 + 20 (x − 3).
    let col = |x: f64| (80.0 + 20.0 * (x - 3.0)) as u32;
    assert!(!is_background(&r.image, col(0.5), 10));
    assert!(!is_background(&r.image, col(5.5), 10));
    for x in [2.0, 3.0, 4.0] {
        assert!(is_background(&r.image, col(x), 10), "x = {x}");
    }
    // Auto framing ignores the non-finite vertices.
    let r = render_tubes(&c.lines(), &RenderOptions::new(160, 20, 0.1)).unwrap();
    let Framing::Fixed {
        center,
        pixels_per_metre,
    } = r.framing
    else {
        panic!()
    };
    assert!(
        center
            .iter()
            .chain([&pixels_per_metre])
            .all(|v| v.is_finite())
    );
    assert!((center[0] - 3.0).abs() < 1e-12);
}

#[test]
fn invalid_options_and_polylines_are_errors() {
    let c = Curves::new(&[&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]]);
    let name = |options: RenderOptions| match render_tubes(&c.lines(), &options) {
        Err(DeformError::Option { name, .. }) => name,
        other => panic!("expected an option error, found {other:?}"),
    };
    assert_eq!(name(RenderOptions::new(0, 10, 0.1)), "render size");
    assert_eq!(name(RenderOptions::new(10, 10, 0.0)), "radius");
    assert_eq!(name(RenderOptions::new(10, 10, f64::NAN)), "radius");
    let parallel = RenderOptions {
        camera: Camera {
            direction: [0.0, 1.0, 0.0],
            up: [0.0, -2.0, 0.0],
        },
        ..RenderOptions::new(10, 10, 0.1)
    };
    assert_eq!(name(parallel), "camera");
    let no_palette = RenderOptions {
        palette: vec![],
        ..RenderOptions::new(10, 10, 0.1)
    };
    assert_eq!(name(no_palette), "palette");
    let offsets = [0u32, 3];
    let bad = Polylines {
        curve_offsets: &offsets,
        ..c.lines()
    };
    assert!(matches!(
        render_tubes(&bad, &RenderOptions::new(10, 10, 0.1)),
        Err(DeformError::Option {
            name: "polylines",
            ..
        })
    ));
}

#[test]
fn deformed_pattern_renders_every_edge() {
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 3.0, 4.0, 4);
    let mut d = deformer::<f32>(&tile, &db, &mesh, DeformOptions::default());
    d.frame(&synthetic::map_uvs(&mesh, |uv| synthetic::wave(uv, 2.0)))
        .unwrap();
    let (e, o) = (d.embedding(), d.output());
    let lines = Polylines {
        x: &o.x,
        y: &o.y,
        z: &o.z,
        curve_offsets: &e.curve_offsets,
        closed: &e.closed,
    };
    let options = RenderOptions {
        camera: Camera {
            direction: [0.3, 0.5, -1.0],
            up: [0.0, 1.0, 0.0],
        },
        supersample: 2,
        ..RenderOptions::new(320, 240, tile.radius)
    };
    let r = render_tubes(&lines, &options).unwrap();
    let edges: usize = (0..e.n_curves())
        .map(|c| {
            let n = (e.curve_offsets[c + 1] - e.curve_offsets[c]) as usize;
            n.saturating_sub(1) + usize::from(e.closed[c] && n > 2) + usize::from(n == 1)
        })
        .sum();
    assert_eq!(r.segments, edges);
    assert_eq!(r.skipped_vertices, 0);
    if let Ok(dir) = std::env::var("RENDER_TEST_DUMP") {
        r.image
            .write_png(&std::path::Path::new(&dir).join("deformed.png"))
            .unwrap();
    }
    // Auto framing: the silhouette's bounding box fills the image minus the 4 % margins along
    // the limiting direction (a capsule's screen extent is its vertices' extent ± R).
    let (mut lo, mut hi) = ([u32::MAX; 2], [0u32; 2]);
    for y in 0..240 {
        for x in 0..320 {
            if !is_background(&r.image, x, y) {
                lo = [lo[0].min(x), lo[1].min(y)];
                hi = [hi[0].max(x), hi[1].max(y)];
            }
        }
    }
    let span = [hi[0] - lo[0] + 1, hi[1] - lo[1] + 1];
    let free = [0.92 * 320.0, 0.92 * 240.0];
    eprintln!("{edges} segments; silhouette {span:?} px, free area {free:?} px");
    assert!(
        (0..2).any(|d| (f64::from(span[d]) - free[d]).abs() <= 2.0),
        "{span:?} vs {free:?}"
    );
    assert!((0..2).all(|d| f64::from(span[d]) <= free[d] + 2.0));
    assert_eq!(decode_png(&r.image.to_png()).rgb, r.image.rgb);
}
