//! The tube renderer and its PNG images: pixels round-trip through the `png` decoder, tube
//! width in pixels, depth ordering, empty input, non-finite vertices, option errors. (A real
//! deformed pattern is rendered in deform-runtime's `pipeline` test.)

use yarn_output::render::{Camera, Framing, Image, RenderOptions, Rendering, render_tubes};
use yarn_output::{OutputError, Polylines};

/// A PNG decoded by the `png` crate: size and 8-bit RGB pixels.
fn decode_png(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .expect("a valid PNG header");
    let mut rgb = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut rgb).expect("valid PNG data");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    rgb.truncate(info.buffer_size());
    (info.width, info.height, rgb)
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
fn png_round_trips_the_pixels() {
    let c = Curves::new(&[&[[-1.0, -0.5, 0.0], [1.0, 0.5, 0.2]], &[[0.0, 0.7, 0.0]]]);
    let r = render_tubes(&c.lines(), &RenderOptions::new(200, 150, 0.1)).unwrap();
    assert_eq!(
        decode_png(&r.image.to_png().unwrap()),
        (200, 150, r.image.rgb.clone())
    );
    assert_eq!(r.segments, 2, "one segment and one single-vertex sphere");
    // A 1 × 1 image is valid too.
    let one = Image {
        width: 1,
        height: 1,
        rgb: vec![1, 2, 3],
    };
    assert_eq!(decode_png(&one.to_png().unwrap()), (1, 1, vec![1, 2, 3]));
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
        assert_eq!(decode_png(&r.image.to_png().unwrap()).2, r.image.rgb);
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
        Err(OutputError::Option { name, .. }) => name,
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
        Err(OutputError::Option {
            name: "polylines",
            ..
        })
    ));
}

/// A triangle mesh drawn with the tubes: a square (two triangles, either winding) in front of
/// a tube hides it where they overlap and is flat-shaded in its colour; behind the tube it is
/// hidden by it; outside the square the tube shows; auto framing fits the mesh; a triangle
/// index beyond the vertices is an error.
#[test]
fn meshes_share_the_depth_buffer_with_the_tubes() {
    use yarn_output::render::{MeshLayer, render_scene};
    let grey = [150, 150, 150];
    let c = Curves::new(&[&[[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]]);
    let square = |z: f64| {
        vec![
            [-0.5, -0.5, z],
            [0.5, -0.5, z],
            [0.5, 0.5, z],
            [-0.5, 0.5, z],
        ]
    };
    let options = RenderOptions {
        palette: vec![[220, 20, 20]],
        ambient: 1.0,
        framing: Framing::Fixed {
            center: [0.0, 0.0],
            pixels_per_metre: 50.0,
        },
        ..RenderOptions::new(101, 101, 0.1)
    };
    for triangles in [[[0, 1, 2], [0, 2, 3]], [[0, 2, 1], [0, 3, 2]]] {
        for (z, mesh_in_front) in [(0.5, true), (-0.5, false)] {
            let positions = square(z);
            let layer = MeshLayer {
                positions: &positions,
                triangles: &triangles,
                colour: grey,
            };
            let r = render_scene(&c.lines(), &[layer], &options).unwrap();
            let centre = r.image.pixel(50, 50);
            if mesh_in_front {
                assert_eq!(centre, grey, "the square hides the tube");
            } else {
                assert_eq!(centre, [220, 20, 20], "the tube hides the square");
            }
            // Off the tube inside the square: the mesh; beyond the square on the tube: the tube.
            assert_eq!(r.image.pixel(50, 70), grey);
            assert_eq!(r.image.pixel(95, 50), [220, 20, 20]);
            assert!(is_background(&r.image, 95, 95));
        }
    }
    // Auto framing fits a mesh larger than the curves.
    let big = square(0.0)
        .into_iter()
        .map(|p| p.map(|x| 4.0 * x))
        .collect::<Vec<_>>();
    let layer = MeshLayer {
        positions: &big,
        triangles: &[[0, 1, 2], [0, 2, 3]],
        colour: grey,
    };
    let auto = render_scene(&c.lines(), &[layer], &RenderOptions::new(100, 100, 0.1)).unwrap();
    match auto.framing {
        Framing::Fixed {
            pixels_per_metre, ..
        } => assert!(pixels_per_metre < 100.0 / 4.0, "{pixels_per_metre}"),
        other => panic!("{other:?}"),
    }
    let bad = MeshLayer {
        positions: &big,
        triangles: &[[0, 1, 4]],
        colour: grey,
    };
    assert!(render_scene(&c.lines(), &[bad], &RenderOptions::new(10, 10, 0.1)).is_err());
}
