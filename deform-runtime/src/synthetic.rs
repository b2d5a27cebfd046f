//! Synthetic inputs for tests, benchmarks and figures: grid and cylinder meshes, and
//! databases whose displacements are a known function of strain.
//!
//! Real databases come from `sim-periodic`; a synthetic one with ΔQ a *multilinear* function
//! of (sx, sa, sy) lets tests check the lookup exactly (trilinear interpolation reproduces
//! multilinear functions) and the mapping independently of the physics.

use yarn_pattern::madypg::Database;
use yarn_pattern::tile::Tile;

use crate::obj::ObjMesh;

/// A flat rectangular grid of `nx × ny` quads (two triangles each) covering
/// `[0, width] × [0, height]` in UV (m); positions equal `(u, v, 0)` (the rest state).
pub fn grid_mesh(nx: usize, ny: usize, width: f64, height: f64) -> ObjMesh {
    let nx = nx.max(1);
    let ny = ny.max(1);
    let mut positions = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            positions.push([
                width * i as f64 / nx as f64,
                height * j as f64 / ny as f64,
                0.0,
            ]);
        }
    }
    let uvs = positions.iter().map(|p| [p[0], p[1]]).collect();
    let mut tris = Vec::with_capacity(2 * nx * ny);
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    for j in 0..ny {
        for i in 0..nx {
            tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    ObjMesh {
        positions,
        uvs,
        tri_uvs: tris.clone(),
        tri_positions: tris,
    }
}

/// Positions of `mesh` mapped by `f` from its UVs (e.g. a deformation of a flat grid).
pub fn map_uvs(mesh: &ObjMesh, f: impl Fn([f64; 2]) -> [f64; 3]) -> Vec<[f64; 3]> {
    // Position k has UV k in meshes from [`grid_mesh`]; in general take the UV of the first
    // corner that references the position.
    let mut uv_of = vec![None; mesh.positions.len()];
    for (tp, tu) in mesh.tri_positions.iter().zip(&mesh.tri_uvs) {
        for c in 0..3 {
            uv_of[tp[c] as usize].get_or_insert(mesh.uvs[tu[c] as usize]);
        }
    }
    uv_of
        .into_iter()
        .map(|uv| f(uv.unwrap_or([0.0, 0.0])))
        .collect()
}

/// The affine map `x = F₂ (u, v)` with `F₂ = √I` of the strain (no rotation), as a closure.
pub fn strain_map(s: [f64; 3]) -> impl Fn([f64; 2]) -> [f64; 3] {
    let f = sqrt_i(s);
    move |uv| {
        [
            f[0] * uv[0] + f[1] * uv[1],
            f[2] * uv[0] + f[3] * uv[1],
            0.0,
        ]
    }
}

/// `√I` (row-major 2 × 2) of the strain `(sx, sa, sy)`.
pub fn sqrt_i(s: [f64; 3]) -> [f64; 4] {
    let strain = yarn_pattern::strain::Strain {
        sx: s[0],
        sa: s[1],
        sy: s[2],
    };
    let r = yarn_pattern::strain::sqrt_spd2(&strain.first_fundamental_form());
    [r[(0, 0)], r[(0, 1)], r[(1, 0)], r[(1, 1)]]
}

/// A database of `tile` sampled on `axes` with rows `f(vertex, (sx, sa, sy))`.
pub fn database(
    tile: &Tile,
    axes: [Vec<f64>; 3],
    f: impl Fn(usize, [f64; 3]) -> [f64; 4],
) -> Database {
    let n = tile.positions.len();
    let [nx, na, ny] = [axes[0].len(), axes[1].len(), axes[2].len()];
    let mut data = vec![[0.0f32; 4]; n * nx * na * ny];
    for v in 0..n {
        for iy in 0..ny {
            for ia in 0..na {
                for ix in 0..nx {
                    let row = ix + nx * (ia + na * (iy + ny * v));
                    let s = [axes[0][ix], axes[1][ia], axes[2][iy]];
                    data[row] = f(v, s).map(|x| x as f32);
                }
            }
        }
    }
    Database {
        axes,
        n_vertices: n,
        data,
    }
}

/// A multilinear displacement (zero at zero strain), scaled by the yarn radius `r` (m):
/// loops tighten along x when stretched along x, and so on. Vertex-dependent through
/// `phase = vertex · 0.37`.
pub fn multilinear(r: f64) -> impl Fn(usize, [f64; 3]) -> [f64; 4] {
    move |v, [sx, sa, sy]| {
        let phase = v as f64 * 0.37;
        let (c, s) = (phase.cos(), phase.sin());
        [
            r * (0.5 * c * sx + 0.2 * sa - 0.1 * s * sy + 0.3 * sx * sa * sy),
            r * (-0.3 * s * sx + 0.1 * c * sa + 0.4 * sy + 0.2 * sx * sy),
            r * (0.2 * sx * sy - 0.1 * sa + 0.05 * c * sx),
            0.1 * sa + 0.05 * s * sx * sy,
        ]
    }
}

/// The published axis layout `sx, sy ∈ [−0.2, 1.0]`, `sa ∈ [−0.7, 0.7]` with `n` samples each.
pub fn uniform_axes(n: usize) -> [Vec<f64>; 3] {
    let n = n.max(2);
    let lin = |a: f64, b: f64| -> Vec<f64> {
        (0..n)
            .map(|k| a + (b - a) * k as f64 / (n - 1) as f64)
            .collect()
    };
    [lin(-0.2, 1.0), lin(-0.7, 0.7), lin(-0.2, 1.0)]
}

/// An open cylinder of radius `r` (m) around the y axis, `nu × nv` quads; UV `u` is the arc
/// length around (0 to `2πr·sweep`, sweep ≤ 1) and `v` the height (0 to `length`).
/// Positions are on the cylinder: the rest mesh is already curved.
pub fn cylinder_mesh(nu: usize, nv: usize, r: f64, sweep: f64, length: f64) -> ObjMesh {
    let mut mesh = grid_mesh(nu, nv, 2.0 * std::f64::consts::PI * r * sweep, length);
    for p in &mut mesh.positions {
        let a = p[0] / r;
        *p = [r * a.sin(), p[1], r * a.cos()];
    }
    mesh
}

/// A smooth non-trivial deformation for benchmarks: stretch, shear and a bending wave (m).
pub fn wave(uv: [f64; 2], amplitude: f64) -> [f64; 3] {
    let [u, v] = uv;
    [
        1.1 * u + 0.01 * (20.0 * v).sin(),
        v + 0.05 * u,
        amplitude * (3.0 * u).sin() * (2.0 * v).cos(),
    ]
}

/// The throughput benchmark's scene: a pattern on a 64 × 64-quad sheet covering
/// `cells × cells` pattern periods (UV in metres), with the synthetic multilinear database on
/// the published 9³ axes, its rest positions, and a frame of [`wave`] (amplitude 0.05 m).
/// Used by the `throughput` bench, the `throughput` figure and the GPU benchmark, so that all
/// three time the same work.
#[derive(Clone, Debug)]
pub struct ThroughputScene<T> {
    /// The deformer (default options).
    pub deformer: crate::deform::Deformer<T>,
    /// Mesh positions of the rest frame (identity: every lookup skipped).
    pub rest: Vec<[f64; 3]>,
    /// Mesh positions of the deformed frame.
    pub moved: Vec<[f64; 3]>,
}

/// Builds [`ThroughputScene`] for `tile` with `cells` periods per side.
pub fn throughput_scene<T: crate::real::Real>(
    tile: &Tile,
    cells: f64,
) -> crate::error::Result<ThroughputScene<T>> {
    let db = database(tile, uniform_axes(9), multilinear(tile.radius));
    let mesh = grid_mesh(64, 64, cells * tile.period[0], cells * tile.period[1]);
    let options = crate::pipeline::SetupOptions {
        uv_scale: 1.0,
        ..Default::default()
    };
    Ok(ThroughputScene {
        deformer: crate::pipeline::build::<T>(tile, &db, &mesh, &options)?,
        rest: map_uvs(&mesh, |uv| [uv[0], uv[1], 0.0]),
        moved: map_uvs(&mesh, |uv| wave(uv, 0.05)),
    })
}
