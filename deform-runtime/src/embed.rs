//! Precompute: tile the pattern over the mesh's UV space and embed every yarn vertex in a
//! triangle (paper 004 §4, "As a precomputation ...").
//!
//! 1. A background grid in UV space with cells of the pattern's periods `a₁ = (px, 0)`,
//!    `a₂ = (skew · px, py)` (rows of rectangles, each row moved by `skew · px` against the one
//!    below on a sheared lattice, [`Tile::skew`]); every cell overlapping the bounding box of a
//!    UV triangle receives a copy of the tile (shifted by integer periods).
//! 2. Each copied vertex is located in the UV mesh (bucketed by the same grid); vertices in
//!    no triangle are cut.
//! 3. Yarns are followed through the periodic edges (`v0 → v1` shifted by the edge's period
//!    shift) into polylines that stop where a vertex was cut; polylines whose material
//!    (rest) length is below `min_fragment_length` are dropped (supplementary S1: aesthetics).
//! 4. Each kept vertex stores its triangle, its UV offset from the triangle's first corner
//!    (barycentrics follow from `Dm⁻¹`, and the offset keeps f32 precise far from the UV
//!    origin), its height `X₃` and its pattern vertex. Vertices are stored curve by curve, so
//!    every curve is a contiguous range ([`Embedding::curve_offsets`]).

use std::collections::HashMap;

use yarn_output::Polylines;
use yarn_pattern::tile::{Tile, Topology};

use crate::error::{DeformError, Result};
use crate::mesh::RestMesh;
use crate::real::Real;

/// Options of the precompute.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EmbedOptions {
    /// Fragments (open yarn pieces) shorter than this material length are dropped (m).
    /// Default 0: keep every fragment with at least two vertices.
    pub min_fragment_length: f64,
    /// Upper bound on candidate vertices (cells × tile vertices), to fail fast on a wrong UV
    /// scale instead of exhausting memory. Default 2³¹ − 1.
    pub max_candidates: u64,
}

impl Default for EmbedOptions {
    fn default() -> Self {
        Self {
            min_fragment_length: 0.0,
            max_candidates: u32::MAX as u64 / 2,
        }
    }
}

/// Counters of the precompute.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct EmbedStats {
    /// Pattern cells copied.
    pub cells: usize,
    /// Candidate vertices (cells × tile vertices).
    pub candidates: usize,
    /// Candidates outside every triangle (cut).
    pub cut_outside: usize,
    /// Vertices dropped with fragments shorter than the minimum length (or single vertices).
    pub dropped_short: usize,
    /// Fragments dropped.
    pub fragments_dropped: usize,
    /// Kept curves.
    pub curves: usize,
    /// Kept closed curves (yarn loops entirely on the mesh).
    pub closed_curves: usize,
    /// Kept yarn vertices.
    pub vertices: usize,
}

/// The embedded yarn vertices, structure-of-arrays.
#[derive(Clone, Debug)]
pub struct Embedding<T> {
    /// Triangle of each yarn vertex.
    pub triangle: Vec<u32>,
    /// UV offset from the triangle's first corner, u component (m).
    pub du: Vec<T>,
    /// UV offset from the triangle's first corner, v component (m).
    pub dv: Vec<T>,
    /// Height `X₃` above the mid-surface (m).
    pub height: Vec<T>,
    /// Pattern (tile) vertex of each yarn vertex.
    pub tile_vertex: Vec<u32>,
    /// Rest material position `X` (m) in f64, for tests and naive comparisons.
    pub material: Vec<[f64; 3]>,
    /// CSR offsets: curve `c` is vertices `curve_offsets[c]..curve_offsets[c+1]`.
    pub curve_offsets: Vec<u32>,
    /// Whether each curve is a closed loop.
    pub closed: Vec<bool>,
    /// Precompute counters.
    pub stats: EmbedStats,
}

impl<T> Embedding<T> {
    /// Number of yarn vertices.
    pub fn len(&self) -> usize {
        self.triangle.len()
    }

    /// Whether there are no yarn vertices.
    pub fn is_empty(&self) -> bool {
        self.triangle.is_empty()
    }

    /// Number of curves.
    pub fn n_curves(&self) -> usize {
        self.closed.len()
    }
}

fn cell_of(x: f64, p: f64) -> i64 {
    (x / p).floor() as i64
}

/// Marks a candidate vertex that lies in no triangle.
const NONE: u32 = u32::MAX;

/// Step 1: the pattern cells overlapping the mesh's UV triangles, with the triangles bucketed
/// by the same grid. Candidate vertex `id = c · n + v` is tile vertex `v` copied into cell `c`.
struct CellGrid {
    /// Pattern period `[px, py]` (m).
    period: [f64; 2],
    /// Lattice skew of the pattern ([`Tile::skew`]).
    skew: f64,
    /// Tile vertices per cell.
    n: usize,
    /// Cell `(i, j)` → its index in `cells`.
    cell_index: HashMap<(i64, i64), u32>,
    /// Integer cell coordinates, in order of first overlap.
    cells: Vec<(i64, i64)>,
    /// Sorted `(cell, triangle)` pairs: the triangles whose bounding box overlaps each cell.
    bucket_pairs: Vec<(u32, u32)>,
    /// CSR offsets of each cell's pairs in `bucket_pairs`.
    bucket_offsets: Vec<u32>,
}

impl CellGrid {
    /// Covers the bounding box of every UV triangle of `mesh` with cells of the pattern
    /// period, failing fast when the candidates exceed `options.max_candidates`.
    fn cover(mesh: &RestMesh, tile: &Tile, options: &EmbedOptions) -> Result<Self> {
        let [px, py] = tile.period;
        let n = tile.positions.len();
        let mut cell_index: HashMap<(i64, i64), u32> = HashMap::new();
        let mut cells: Vec<(i64, i64)> = Vec::new();
        let mut bucket_pairs: Vec<(u32, u32)> = Vec::new();
        let mut candidates: u64 = 0;
        for (f, t) in mesh.triangles.iter().enumerate() {
            let uv = t.map(|v| mesh.vertex_uv[v as usize]);
            let (u0, u1) = (
                uv.iter().map(|x| x[0]).fold(f64::INFINITY, f64::min),
                uv.iter().map(|x| x[0]).fold(f64::NEG_INFINITY, f64::max),
            );
            let (v0, v1) = (
                uv.iter().map(|x| x[1]).fold(f64::INFINITY, f64::min),
                uv.iter().map(|x| x[1]).fold(f64::NEG_INFINITY, f64::max),
            );
            let (j0, j1) = (cell_of(v0, py), cell_of(v1, py));
            // Row j of cells starts at skew · px · j: the cells of each row over [u0, u1].
            let row = |j: i64| {
                let start = tile.skew * px * j as f64;
                (cell_of(u0 - start, px), cell_of(u1 - start, px))
            };
            // Cells to cover, without visiting them (a wrong UV scale must fail fast): rows
            // times columns, the columns of a sheared row bounded by one more than fit.
            let columns = if tile.skew == 0.0 {
                cell_of(u1, px) - cell_of(u0, px) + 1
            } else {
                ((u1 - u0) / px).floor() as i64 + 2
            };
            let area = (columns as u64).saturating_mul((j1 - j0 + 1) as u64);
            if area.saturating_mul(n as u64) > options.max_candidates {
                return Err(DeformError::Option {
                    name: "uv_scale",
                    message: format!(
                        "triangle {f} covers {area} pattern cells; more than the candidate limit {} — is the UV scale right?",
                        options.max_candidates
                    ),
                });
            }
            // Columns outer, rows inner (the order of the rectangular grid's cells, which
            // numbers the candidates), each row's own columns only.
            let (i_min, i_max) = (j0..=j1)
                .map(row)
                .fold((i64::MAX, i64::MIN), |(a, b), (i0, i1)| {
                    (a.min(i0), b.max(i1))
                });
            for i in i_min..=i_max {
                for j in (j0..=j1).filter(|&j| {
                    let (i0, i1) = row(j);
                    (i0..=i1).contains(&i)
                }) {
                    let next = cells.len() as u32;
                    let c = *cell_index.entry((i, j)).or_insert_with(|| {
                        cells.push((i, j));
                        candidates += n as u64;
                        next
                    });
                    bucket_pairs.push((c, f as u32));
                }
            }
            if candidates > options.max_candidates {
                return Err(DeformError::Option {
                    name: "uv_scale",
                    message: format!(
                        "more than {} candidate yarn vertices — is the UV scale right?",
                        options.max_candidates
                    ),
                });
            }
        }
        let nc = cells.len();
        bucket_pairs.sort_unstable();
        let mut bucket_offsets = vec![0u32; nc + 1];
        for &(c, _) in &bucket_pairs {
            bucket_offsets[c as usize + 1] += 1;
        }
        for c in 0..nc {
            bucket_offsets[c + 1] += bucket_offsets[c];
        }
        Ok(Self {
            period: tile.period,
            skew: tile.skew,
            n,
            cell_index,
            cells,
            bucket_pairs,
            bucket_offsets,
        })
    }

    /// The cell `(i, j)` holding the UV point `(u, w)`: its row first, then the cell along it.
    fn cell_at(&self, u: f64, w: f64) -> (i64, i64) {
        let [px, py] = self.period;
        let j = cell_of(w, py);
        (cell_of(u - self.skew * px * j as f64, px), j)
    }

    /// The UV translation (m) of the tile copy in cell `(i, j)`: `i a₁ + j a₂`.
    fn copy_offset(&self, (i, j): (i64, i64)) -> [f64; 2] {
        let [px, py] = self.period;
        [(i as f64 + self.skew * j as f64) * px, j as f64 * py]
    }

    /// Number of candidate vertices (cells × tile vertices).
    fn n_candidates(&self) -> usize {
        self.cells.len() * self.n
    }

    /// The triangle of the cell's bucket containing the UV point `(u, w)` (within `1e-12` in
    /// barycentrics) and the point's UV offset from the triangle's first corner.
    fn locate(&self, mesh: &RestMesh, u: f64, w: f64) -> Option<(u32, [f64; 2])> {
        let eps = 1e-12;
        let &b = self.cell_index.get(&self.cell_at(u, w))?;
        let range =
            self.bucket_offsets[b as usize] as usize..self.bucket_offsets[b as usize + 1] as usize;
        self.bucket_pairs[range].iter().find_map(|&(_, f)| {
            let t = mesh.triangles[f as usize];
            let o = mesh.vertex_uv[t[0] as usize];
            let d = [u - o[0], w - o[1]];
            let m = mesh.dm_inv[f as usize];
            let b1 = m[0] * d[0] + m[1] * d[1];
            let b2 = m[2] * d[0] + m[3] * d[1];
            (b1 >= -eps && b2 >= -eps && b1 + b2 <= 1.0 + eps).then_some((f, d))
        })
    }

    /// Rest material position `X` (m) of candidate `id`: its tile vertex shifted by its cell.
    fn material(&self, tile: &Tile, id: usize) -> [f64; 3] {
        let (c, v) = (id / self.n, id % self.n);
        let [du, dv] = self.copy_offset(self.cells[c]);
        let x = tile.positions[v];
        [x.x + du, x.y + dv, x.z]
    }
}

/// Step 2: every candidate vertex located in the UV mesh.
struct Located {
    /// Triangle of each candidate ([`NONE`]: cut).
    triangle: Vec<u32>,
    /// UV offset of each located candidate from its triangle's first corner (m).
    offset: Vec<[f64; 2]>,
    /// Candidates in no triangle.
    cut_outside: usize,
}

impl Located {
    /// Locates every candidate of `grid` in `mesh`.
    fn locate(mesh: &RestMesh, tile: &Tile, grid: &CellGrid) -> Self {
        let n = grid.n;
        let mut triangle: Vec<u32> = vec![NONE; grid.n_candidates()];
        let mut offset: Vec<[f64; 2]> = vec![[0.0; 2]; grid.n_candidates()];
        let mut cut_outside = 0usize;
        for (c, &cell) in grid.cells.iter().enumerate() {
            let [du, dv] = grid.copy_offset(cell);
            for v in 0..n {
                let x = tile.positions[v];
                let (u, w) = (x.x + du, x.y + dv);
                match grid.locate(mesh, u, w) {
                    Some((f, d)) => {
                        triangle[c * n + v] = f;
                        offset[c * n + v] = d;
                    }
                    None => cut_outside += 1,
                }
            }
        }
        Self {
            triangle,
            offset,
            cut_outside,
        }
    }
}

/// Step 3: the yarns followed through the periodic edges into chains of located candidates,
/// each with whether it closes into a loop. Chains start where the previous vertex was cut;
/// the remaining unvisited candidates form closed loops (or chains ending in a visited one).
fn follow_yarns(
    tile: &Tile,
    topology: &Topology,
    grid: &CellGrid,
    located: &Located,
) -> Vec<(Vec<usize>, bool)> {
    let n = grid.n;
    let located = &located.triangle;
    // Candidate of tile vertex `v` in the cell at `key`, if that cell exists and `v` is located.
    let candidate = |key: (i64, i64), v: usize| -> Option<usize> {
        let &c2 = grid.cell_index.get(&key)?;
        let id = c2 as usize * n + v;
        (located[id] != NONE).then_some(id)
    };
    let next_of = |c: usize, v: usize| -> Option<usize> {
        let e = tile.edges[topology.outgoing(v)];
        let (i, j) = grid.cells[c];
        candidate((i + i64::from(e.shift[0]), j + i64::from(e.shift[1])), e.v1)
    };
    let prev_of = |c: usize, v: usize| -> Option<usize> {
        let e = tile.edges[topology.incoming(v)];
        let (i, j) = grid.cells[c];
        candidate((i - i64::from(e.shift[0]), j - i64::from(e.shift[1])), e.v0)
    };
    let mut visited = vec![false; grid.n_candidates()];
    let mut curves: Vec<(Vec<usize>, bool)> = Vec::new();
    let mut chain = Vec::new();
    let follow = |start: usize, visited: &mut Vec<bool>, chain: &mut Vec<usize>| -> bool {
        chain.clear();
        let mut id = start;
        loop {
            visited[id] = true;
            chain.push(id);
            match next_of(id / n, id % n) {
                Some(next) if next == start => return true,
                Some(next) if !visited[next] => id = next,
                _ => return false,
            }
        }
    };
    for id in 0..grid.n_candidates() {
        if located[id] != NONE && !visited[id] && prev_of(id / n, id % n).is_none() {
            let closed = follow(id, &mut visited, &mut chain);
            curves.push((chain.clone(), closed));
        }
    }
    for id in 0..grid.n_candidates() {
        if located[id] != NONE && !visited[id] {
            let closed = follow(id, &mut visited, &mut chain);
            curves.push((chain.clone(), closed));
        }
    }
    curves
}

/// Step 4: drops the fragments shorter than `options.min_fragment_length` (or with a single
/// vertex) and stores the kept curves, curve by curve, with the counters.
fn store_curves<T: Real>(
    tile: &Tile,
    grid: &CellGrid,
    located: &Located,
    curves: Vec<(Vec<usize>, bool)>,
    options: &EmbedOptions,
) -> Embedding<T> {
    let mut stats = EmbedStats {
        cells: grid.cells.len(),
        candidates: grid.n_candidates(),
        cut_outside: located.cut_outside,
        ..EmbedStats::default()
    };
    let mut out = Embedding {
        triangle: Vec::new(),
        du: Vec::new(),
        dv: Vec::new(),
        height: Vec::new(),
        tile_vertex: Vec::new(),
        material: Vec::new(),
        curve_offsets: vec![0],
        closed: Vec::new(),
        stats,
    };
    for (chain, closed) in curves {
        let mut length = 0.0;
        for w in chain.windows(2) {
            let (a, b) = (grid.material(tile, w[0]), grid.material(tile, w[1]));
            length +=
                ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        }
        if chain.len() < 2 || length < options.min_fragment_length {
            stats.dropped_short += chain.len();
            stats.fragments_dropped += 1;
            continue;
        }
        for &id in &chain {
            out.triangle.push(located.triangle[id]);
            out.du.push(T::from_f64(located.offset[id][0]));
            out.dv.push(T::from_f64(located.offset[id][1]));
            let m = grid.material(tile, id);
            out.height.push(T::from_f64(m[2]));
            out.tile_vertex.push((id % grid.n) as u32);
            out.material.push(m);
        }
        out.curve_offsets.push(out.triangle.len() as u32);
        out.closed.push(closed);
        stats.curves += 1;
        stats.closed_curves += usize::from(closed);
    }
    stats.vertices = out.triangle.len();
    out.stats = stats;
    out
}

/// Tiles `tile` over `mesh` and embeds the yarn vertices (see the module docs).
pub fn embed<T: Real>(
    mesh: &RestMesh,
    tile: &Tile,
    options: &EmbedOptions,
) -> Result<Embedding<T>> {
    let topology = tile.topology()?;
    if !(options.min_fragment_length >= 0.0 && options.min_fragment_length.is_finite()) {
        return Err(DeformError::Option {
            name: "min_fragment_length",
            message: format!(
                "expected a finite length ≥ 0 m, found {}",
                options.min_fragment_length
            ),
        });
    }
    let grid = CellGrid::cover(mesh, tile, options)?;
    let located = Located::locate(mesh, tile, &grid);
    let curves = follow_yarns(tile, &topology, &grid, &located);
    let out = store_curves(tile, &grid, &located, curves, options);
    if out.is_empty() {
        return Err(DeformError::EmptyEmbedding {
            uv_area: mesh.total_uv_area(),
            period: tile.period,
        });
    }
    Ok(out)
}

impl<T> Embedding<T> {
    /// The yarn curves of a deformed frame: `output`'s coordinates (m) with this embedding's
    /// curve offsets and closed flags, ready for the `yarn-output` writers and renderer.
    pub fn polylines<'a>(&'a self, output: &'a crate::kernel::YarnOutput<T>) -> Polylines<'a, T> {
        Polylines {
            x: &output.x,
            y: &output.y,
            z: &output.z,
            curve_offsets: &self.curve_offsets,
            closed: &self.closed,
        }
    }
}
