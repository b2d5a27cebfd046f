//! The `f32` per-vertex kernel in SIMD lanes: the CPU loop that
//! [`crate::deform::Deformer::frame`] runs in production precision.
//!
//! It computes exactly what [`crate::kernel::deform_vertex`] computes for each vertex, with
//! the same operations in the same order, so its output is bit-identical to that reference
//! (tested); the `f64` path runs the reference itself. What differs is how the work is laid
//! out for the machine:
//!
//! - **Lanes.** A batch is one SIMD vector of consecutive yarn vertices (eight on AVX2). The
//!   strains and the world map run as vector instructions; the branches of the reference
//!   (eigenvalue clamping, the zero-normal fallback, skipped or non-finite lookups, the
//!   non-finite store) are selects.
//! - **Faces hoisted.** Yarn vertices are stored curve by curve and a curve stays in one
//!   triangle for many consecutive vertices, so most batches lie in one face. Such a batch
//!   broadcasts the face's polynomial coefficients once (`OneFace`) instead of reading one
//!   192-byte record per vertex; a batch across a face boundary gathers them per lane
//!   (`LaneFaces`). Both are the same code, instantiated twice. A batch on one identity face
//!   skips the strain and lookup phases entirely.
//! - **Lookup.** On uniform axes (every generated database) the sample location, the corner
//!   weights and the trilinear blend run in lanes, with the operations of
//!   [`crate::database::locate_uniform`] and [`RuntimeDatabase::interpolate`]. The database is
//!   stored for this ([`crate::database`]): when every lane of a batch lies in one sample cell
//!   on consecutive storage slots, each corner's component is one vector load; otherwise it
//!   is gathered lane by lane. Non-uniform axes use the reference lookup per lane.
//! - **Instruction set.** [`run`] dispatches once per chunk, through `pulp`, to the best
//!   instruction set of the machine (AVX2 + FMA on x86-64 when present, else the baseline),
//!   since the default x86-64 target has only SSE2. No fused multiply-add is formed: products
//!   and sums stay separate operations, which is what keeps the output bit-identical to the
//!   reference.
//!
//! The vertices of a chunk that do not fill a last batch run through the reference.

use pulp::Simd;
use pulp::bytemuck;

use crate::database::RuntimeDatabase;
use crate::embed::Embedding;
use crate::kernel::{KernelInputs, VertexCounters, deform_vertex};
use crate::mesh::FacePoly;
use crate::real::Real;

/// The most lanes of one batch on any instruction set `pulp` dispatches to.
const MAX_LANES: usize = 16;

/// The lanes of a vector, readable one by one.
#[inline(always)]
fn lanes<S: Simd>(v: &S::f32s) -> &[f32] {
    bytemuck::cast_slice(std::slice::from_ref(v))
}

/// The lanes of an integer vector.
#[inline(always)]
fn lanes_u32<S: Simd>(v: &S::u32s) -> &[u32] {
    bytemuck::cast_slice(std::slice::from_ref(v))
}

/// A vector from one value per lane (`f` only reads memory: closures here never call SIMD
/// methods, which would not be compiled for the dispatched instruction set).
#[inline(always)]
fn gather<S: Simd>(simd: S, f: impl Fn(usize) -> f32) -> S::f32s {
    if S::F32_LANES == 8 {
        // Built in registers (a store of lanes followed by a vector load would stall on
        // store-to-load forwarding).
        let mut a = [0.0f32; 8];
        for (l, x) in a.iter_mut().enumerate() {
            *x = f(l);
        }
        return bytemuck::cast(a);
    }
    let mut v = simd.splat_f32s(0.0);
    let dst: &mut [f32] = bytemuck::cast_slice_mut(std::slice::from_mut(&mut v));
    for (l, x) in dst.iter_mut().enumerate() {
        *x = f(l);
    }
    v
}

/// `a + b`.
#[inline(always)]
fn add<S: Simd>(simd: S, a: S::f32s, b: S::f32s) -> S::f32s {
    simd.add_f32s(a, b)
}

/// `a − b`.
#[inline(always)]
fn sub<S: Simd>(simd: S, a: S::f32s, b: S::f32s) -> S::f32s {
    simd.sub_f32s(a, b)
}

/// `a · b`.
#[inline(always)]
fn mul<S: Simd>(simd: S, a: S::f32s, b: S::f32s) -> S::f32s {
    simd.mul_f32s(a, b)
}

/// `a + b·c`, unfused (as the reference computes it).
#[inline(always)]
fn add_mul<S: Simd>(simd: S, a: S::f32s, b: S::f32s, c: S::f32s) -> S::f32s {
    simd.add_f32s(a, simd.mul_f32s(b, c))
}

/// One corner of the trilinear blend, in the reference's order:
/// `acc + w · (t₀ · a + t₁ · b)` ([`RuntimeDatabase::interpolate`]).
#[inline(always)]
fn blend<S: Simd>(
    simd: S,
    acc: S::f32s,
    w: S::f32s,
    (t0, t1): (S::f32s, S::f32s),
    (a, b): (S::f32s, S::f32s),
) -> S::f32s {
    add_mul(simd, acc, w, add(simd, mul(simd, t0, a), mul(simd, t1, b)))
}

/// Lanes whose value is finite.
#[inline(always)]
fn finite<S: Simd>(simd: S, v: S::f32s) -> S::m32s {
    simd.less_than_f32s(simd.abs_f32s(v), simd.splat_f32s(f32::INFINITY))
}

/// A mask as one integer per lane: 1 where it holds, else 0.
#[inline(always)]
fn bits<S: Simd>(simd: S, mask: S::m32s) -> S::u32s {
    simd.select_u32s(mask, simd.splat_u32s(1), simd.splat_u32s(0))
}

/// Lanes where `mask` holds (a horizontal sum in registers).
#[inline(always)]
fn count<S: Simd>(simd: S, mask: S::m32s) -> usize {
    let ones = simd.select_f32s(mask, simd.splat_f32s(1.0), simd.splat_f32s(0.0));
    simd.reduce_sum_f32s(ones) as usize
}

/// Where each lane's face polynomial comes from.
trait Faces {
    /// The coefficient `get` of each lane's face, as a vector.
    fn coef<S: Simd>(&self, simd: S, get: impl Fn(&FacePoly<f32>) -> f32) -> S::f32s;
}

/// Every lane in one face: the coefficients are read once and broadcast.
struct OneFace<'a>(&'a FacePoly<f32>);

impl Faces for OneFace<'_> {
    #[inline(always)]
    fn coef<S: Simd>(&self, simd: S, get: impl Fn(&FacePoly<f32>) -> f32) -> S::f32s {
        simd.splat_f32s(get(self.0))
    }
}

/// Lanes in different faces: each lane reads its own face.
struct LaneFaces<'a> {
    faces: &'a [FacePoly<f32>],
    triangles: &'a [u32],
}

impl Faces for LaneFaces<'_> {
    #[inline(always)]
    fn coef<S: Simd>(&self, simd: S, get: impl Fn(&FacePoly<f32>) -> f32) -> S::f32s {
        gather(simd, |l| get(&self.faces[self.triangles[l] as usize]))
    }
}

/// The per-vertex stage of one chunk: vertices `start..start + out[0].len()` of `e`, written
/// to `out = [x, y, z, twist]` (chunk-local), counters added to `counters`.
pub fn run(
    input: &KernelInputs<'_, f32>,
    e: &Embedding<f32>,
    start: usize,
    out: &mut [&mut [f32]; 4],
    counters: &mut VertexCounters,
) {
    pulp::Arch::new().dispatch(Chunk {
        input,
        e,
        start,
        out,
        counters,
    });
}

/// One chunk of [`run`], as a `pulp` operation so that its body is compiled for the
/// instruction set that `dispatch` selects.
struct Chunk<'a, 'b> {
    input: &'a KernelInputs<'a, f32>,
    e: &'a Embedding<f32>,
    start: usize,
    out: &'a mut [&'b mut [f32]; 4],
    counters: &'a mut VertexCounters,
}

/// The per-vertex inputs of one batch.
struct Batch<'a, S: Simd> {
    triangles: &'a [u32],
    tile_vertices: &'a [u32],
    du: S::f32s,
    dv: S::f32s,
    height: S::f32s,
}

impl pulp::WithSimd for Chunk<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let Chunk {
            input,
            e,
            start,
            out,
            counters,
        } = self;
        let w = S::F32_LANES;
        assert!(w <= MAX_LANES, "{w} lanes");
        let n = out[0].len();
        let full = n - n % w;
        let range = start..start + full;
        let (du, _) = S::as_simd_f32s(&e.du[range.clone()]);
        let (dv, _) = S::as_simd_f32s(&e.dv[range.clone()]);
        let (height, _) = S::as_simd_f32s(&e.height[range.clone()]);
        let triangles = &e.triangle[range.clone()];
        let tile_vertices = &e.tile_vertex[range];
        for b in 0..full / w {
            let j = b * w;
            let batch = Batch::<S> {
                triangles: &triangles[j..j + w],
                tile_vertices: &tile_vertices[j..j + w],
                du: du[b],
                dv: dv[b],
                height: height[b],
            };
            let t0 = batch.triangles[0];
            let x = if batch.triangles.iter().all(|&t| t == t0) {
                let face = OneFace(&input.faces[t0 as usize]);
                vertex(simd, input, &face, &batch, counters)
            } else {
                let faces = LaneFaces {
                    faces: input.faces,
                    triangles: batch.triangles,
                };
                vertex(simd, input, &faces, &batch, counters)
            };
            // Store: non-finite results keep the previous output.
            let ok = simd.and_m32s(
                simd.and_m32s(finite(simd, x[0]), finite(simd, x[1])),
                simd.and_m32s(finite(simd, x[2]), finite(simd, x[3])),
            );
            let n_ok = count(simd, ok);
            counters.nonfinite_output += w - n_ok;
            if n_ok == w {
                for c in 0..4 {
                    let (dst, _) = S::as_mut_simd_f32s(&mut out[c][j..j + w]);
                    dst[0] = x[c];
                }
            } else {
                // Plain stores of the finite lanes (a select against the old value would
                // compile to a masked store, which is slow on some processors).
                let ok = bits(simd, ok);
                let ok = lanes_u32::<S>(&ok);
                for c in 0..4 {
                    let x = lanes::<S>(&x[c]);
                    for l in 0..w {
                        if ok[l] != 0 {
                            out[c][j + l] = x[l];
                        }
                    }
                }
            }
        }
        each_vertex(
            e,
            start,
            full,
            out,
            counters,
            |f, du, dv, h, v, counters| deform_vertex(input, f, du, dv, h, v, counters),
        );
    }
}

/// One batch through every phase: its output `(x, y, z, θ)`, component-major.
#[inline(always)]
fn vertex<S: Simd, F: Faces>(
    simd: S,
    input: &KernelInputs<'_, f32>,
    faces: &F,
    b: &Batch<'_, S>,
    counters: &mut VertexCounters,
) -> [S::f32s; 4] {
    let dq = if input.options.displacement {
        displacement(simd, input, faces, b, counters)
    } else {
        [simd.splat_f32s(0.0); 4]
    };
    world_map(simd, input, faces, b, &dq)
}

/// The zero-strain displacement of each lane (for lanes that do not look up).
#[inline(always)]
fn rest<S: Simd>(simd: S, input: &KernelInputs<'_, f32>, b: &Batch<'_, S>) -> [S::f32s; 4] {
    let mut rest = [simd.splat_f32s(0.0); 4];
    for (c, r) in rest.iter_mut().enumerate() {
        *r = gather(simd, |l| input.rest_dq[b.tile_vertices[l] as usize][c]);
    }
    rest
}

/// Phases 1–2 (steps 1–5 of [`crate::deform`]).
#[inline(always)]
fn displacement<S: Simd, F: Faces>(
    simd: S,
    input: &KernelInputs<'_, f32>,
    faces: &F,
    b: &Batch<'_, S>,
    counters: &mut VertexCounters,
) -> [S::f32s; 4] {
    let w = S::F32_LANES;
    let o = input.options;
    let mut skip = [false; MAX_LANES];
    let mut n_skip = 0;
    for l in 0..w {
        skip[l] = o.skip_identity && input.skip[b.triangles[l] as usize] != 0;
        n_skip += usize::from(skip[l]);
    }
    counters.lookups_skipped += n_skip;
    if n_skip == w {
        return rest(simd, input, b);
    }
    let (du, dv) = (b.du, b.dv);
    // Phase 1: I(h), clamped, and its strains (Eqs. 4, 7; §4.3).
    let mut i = [simd.splat_f32s(0.0); 3];
    for (c, i) in i.iter_mut().enumerate() {
        let x = add_mul(
            simd,
            faces.coef(simd, |f| f.i0[c]),
            faces.coef(simd, |f| f.il[c]),
            du,
        );
        *i = add_mul(simd, x, faces.coef(simd, |f| f.il[3 + c]), dv);
    }
    if o.linearized_bending {
        let two_h = add(simd, b.height, b.height);
        for (c, i) in i.iter_mut().enumerate() {
            let ii = add_mul(
                simd,
                faces.coef(simd, |f| f.ii0[c]),
                faces.coef(simd, |f| f.iil[c]),
                du,
            );
            let ii = add_mul(simd, ii, faces.coef(simd, |f| f.iil[3 + c]), dv);
            *i = sub(simd, *i, mul(simd, two_h, ii));
        }
    }
    let floor = simd.splat_f32s(input.eigen_floor);
    let (zero, one, half) = (
        simd.splat_f32s(0.0),
        simd.splat_f32s(1.0),
        simd.splat_f32s(0.5),
    );
    // clamp_eigenvalues, branch-free.
    let [a, bb, c] = i;
    let m = mul(simd, half, add(simd, a, c));
    let h = mul(simd, half, sub(simd, a, c));
    let d = simd.sqrt_f32s(add(simd, mul(simd, h, h), mul(simd, bb, bb)));
    let l2 = sub(simd, m, d);
    let keep = simd.greater_than_or_equal_f32s(l2, floor);
    let n_keep = count(simd, keep);
    let (ca, cb, cc) = if n_keep == w {
        (a, bb, c)
    } else {
        let l1 = simd.max_f32s(add(simd, m, d), floor);
        let inv = simd.div_f32s(one, add(simd, d, d));
        let p_a = mul(simd, sub(simd, a, l2), inv);
        let p_b = mul(simd, bb, inv);
        let p_c = mul(simd, sub(simd, c, l2), inv);
        let k = sub(simd, l1, floor);
        let spread = simd.greater_than_f32s(d, zero);
        let ca = simd.select_f32s(spread, add_mul(simd, floor, k, p_a), floor);
        let cb = simd.select_f32s(spread, mul(simd, k, p_b), zero);
        let cc = simd.select_f32s(spread, add_mul(simd, floor, k, p_c), floor);
        (
            simd.select_f32s(keep, a, ca),
            simd.select_f32s(keep, bb, cb),
            simd.select_f32s(keep, c, cc),
        )
    };
    // strains
    let (ra, rc) = (simd.sqrt_f32s(ca), simd.sqrt_f32s(cc));
    let s = [
        sub(simd, ra, one),
        simd.div_f32s(cb, mul(simd, ra, rc)),
        sub(simd, rc, one),
    ];
    let ok = simd.and_m32s(
        simd.and_m32s(finite(simd, s[0]), finite(simd, s[1])),
        finite(simd, s[2]),
    );
    // Lanes that look up: finite strains on faces that are not skipped.
    let n_ok = count(simd, ok);
    let lookup = if n_skip == 0 {
        counters.clamped += w - n_keep;
        counters.nonfinite_strain += w - n_ok;
        ok
    } else {
        let live = gather(simd, |l| if skip[l] { 0.0 } else { 1.0 });
        let live = simd.greater_than_f32s(live, zero);
        counters.clamped += count(simd, simd.and_m32s(simd.not_m32s(keep), live));
        counters.nonfinite_strain += count(simd, simd.and_m32s(simd.not_m32s(ok), live));
        simd.and_m32s(ok, live)
    };
    // Phase 2: trilinear lookup (§4.4).
    let db: &RuntimeDatabase<f32> = input.db;
    let Some((a0, inv)) = db.uniform_grid() else {
        // Non-uniform axes: the reference lookup, lane by lane.
        let s = [lanes::<S>(&s[0]), lanes::<S>(&s[1]), lanes::<S>(&s[2])];
        let lookup = bits(simd, lookup);
        let lookup = lanes_u32::<S>(&lookup);
        let mut dq = rest(simd, input, b);
        for (c, dq) in dq.iter_mut().enumerate() {
            let r = *dq;
            let r = lanes::<S>(&r);
            *dq = gather(simd, |l| {
                if lookup[l] != 0 {
                    db.lookup(b.tile_vertices[l] as usize, [s[0][l], s[1][l], s[2][l]])[c]
                } else {
                    r[l]
                }
            });
        }
        return dq;
    };
    // locate_uniform in lanes, the same operations; the integer part of t ∈ [0, n − 1] is
    // exact through 2²³ (adding and subtracting it rounds to an integer).
    let shape = db.shape();
    let big = simd.splat_f32s(8_388_608.0);
    let mut lo = [zero; 3];
    let mut frac = [zero; 3];
    for q in 0..3 {
        let last = simd.splat_f32s((shape[q] - 1) as f32);
        let t = sub(simd, s[q], simd.splat_f32s(a0[q]));
        let t = mul(simd, t, simd.splat_f32s(inv[q]));
        let t = simd.select_f32s(simd.greater_than_f32s(t, zero), t, zero);
        let t = simd.select_f32s(simd.less_than_f32s(t, last), t, last);
        let r = sub(simd, add(simd, t, big), big);
        let r = simd.select_f32s(simd.greater_than_f32s(r, t), sub(simd, r, one), r);
        lo[q] = simd.min_f32s(r, simd.splat_f32s((shape[q] - 2) as f32));
        frac[q] = sub(simd, t, lo[q]);
    }
    // The weights of the four (sa, sy) corners and of the two sx samples.
    let (ua, uy) = (sub(simd, one, frac[1]), sub(simd, one, frac[2]));
    let corner = [
        mul(simd, ua, uy),
        mul(simd, frac[1], uy),
        mul(simd, ua, frac[2]),
        mul(simd, frac[1], frac[2]),
    ];
    let (tx0, tx1) = (sub(simd, one, frac[0]), frac[0]);
    let (nx, na, nv) = (shape[0], shape[1], db.n_vertices());
    let texels = db.texels();
    let rows = |ix: usize, ia: usize, iy: usize| {
        [
            nx * (ia + na * iy) + ix,
            nx * (ia + 1 + na * iy) + ix,
            nx * (ia + na * (iy + 1)) + ix,
            nx * (ia + 1 + na * (iy + 1)) + ix,
        ]
    };
    let mut acc = [zero; 4];
    let mut slot = [0usize; MAX_LANES];
    for l in 0..w {
        slot[l] = db.slot(b.tile_vertices[l] as usize);
    }
    let v0 = slot[0];
    let consecutive = v0 + w <= nv && (0..w).all(|l| slot[l] == v0 + l);
    let lo0 = [
        lanes::<S>(&lo[0])[0],
        lanes::<S>(&lo[1])[0],
        lanes::<S>(&lo[2])[0],
    ];
    let same_x = simd.equal_f32s(lo[0], simd.splat_f32s(lo0[0]));
    let same_a = simd.equal_f32s(lo[1], simd.splat_f32s(lo0[1]));
    let same_y = simd.equal_f32s(lo[2], simd.splat_f32s(lo0[2]));
    let contiguous =
        consecutive && count(simd, simd.and_m32s(simd.and_m32s(same_x, same_a), same_y)) == w;
    if contiguous {
        // Every lane in one sample cell, on consecutive pattern vertices: each corner's
        // component is one contiguous vector.
        let rows = rows(lo0[0] as usize, lo0[1] as usize, lo0[2] as usize);
        for k in 0..4 {
            for (c, acc) in acc.iter_mut().enumerate() {
                let ia = db.index(rows[k], c, v0);
                let ib = db.index(rows[k] + 1, c, v0);
                let ta = S::as_simd_f32s(&texels[ia..ia + w]).0[0];
                let tb = S::as_simd_f32s(&texels[ib..ib + w]).0[0];
                *acc = blend(simd, *acc, corner[k], (tx0, tx1), (ta, tb));
            }
        }
    } else {
        // Lanes in different cells or on scattered slots: the same sums, each corner's
        // component gathered lane by lane.
        let lo = [lanes::<S>(&lo[0]), lanes::<S>(&lo[1]), lanes::<S>(&lo[2])];
        let mut lane_rows = [[0usize; 4]; MAX_LANES];
        for l in 0..w {
            lane_rows[l] = rows(lo[0][l] as usize, lo[1][l] as usize, lo[2][l] as usize);
        }
        for k in 0..4 {
            for (c, acc) in acc.iter_mut().enumerate() {
                let ta = gather(simd, |l| texels[db.index(lane_rows[l][k], c, slot[l])]);
                let tb = gather(simd, |l| texels[db.index(lane_rows[l][k] + 1, c, slot[l])]);
                *acc = blend(simd, *acc, corner[k], (tx0, tx1), (ta, tb));
            }
        }
    }
    if n_skip == 0 && n_ok == w {
        return acc;
    }
    let mut dq = rest(simd, input, b);
    for c in 0..4 {
        dq[c] = simd.select_f32s(lookup, acc[c], dq[c]);
    }
    dq
}

/// Phase 3 (steps 6–7 of [`crate::deform`]): each lane's displaced material point mapped to
/// world space, and its twist.
#[inline(always)]
fn world_map<S: Simd, F: Faces>(
    simd: S,
    input: &KernelInputs<'_, f32>,
    faces: &F,
    b: &Batch<'_, S>,
    dq: &[S::f32s; 4],
) -> [S::f32s; 4] {
    let (u, v) = (add(simd, b.du, dq[0]), add(simd, b.dv, dq[1]));
    let h = add(simd, b.height, dq[2]);
    let (uu, uv, vv) = (mul(simd, u, u), mul(simd, u, v), mul(simd, v, v));
    let mut n = [simd.splat_f32s(0.0); 3];
    for (c, n) in n.iter_mut().enumerate() {
        let x = add_mul(
            simd,
            faces.coef(simd, |f| f.n0[c]),
            faces.coef(simd, |f| f.nl[c]),
            u,
        );
        *n = add_mul(simd, x, faces.coef(simd, |f| f.nl[3 + c]), v);
    }
    let len2 = add(simd, mul(simd, n[0], n[0]), mul(simd, n[1], n[1]));
    let len2 = add(simd, len2, mul(simd, n[2], n[2]));
    let nonzero = simd.greater_than_f32s(len2, simd.splat_f32s(0.0));
    let inv = simd.div_f32s(simd.splat_f32s(1.0), simd.sqrt_f32s(len2));
    let mut x = [simd.splat_f32s(0.0); 4];
    for c in 0..3 {
        let p = add_mul(
            simd,
            faces.coef(simd, |f| f.x0[c]),
            faces.coef(simd, |f| f.xl[c]),
            u,
        );
        let p = add_mul(simd, p, faces.coef(simd, |f| f.xl[3 + c]), v);
        let p = add_mul(simd, p, faces.coef(simd, |f| f.xq[c]), uu);
        let p = add_mul(simd, p, faces.coef(simd, |f| f.xq[3 + c]), uv);
        let p = add_mul(simd, p, faces.coef(simd, |f| f.xq[6 + c]), vv);
        let normal = simd.select_f32s(nonzero, mul(simd, n[c], inv), faces.coef(simd, |f| f.nf[c]));
        x[c] = add_mul(simd, p, h, normal);
    }
    let rest_twist = gather(simd, |l| input.twists[b.tile_vertices[l] as usize]);
    x[3] = add(simd, rest_twist, dq[3]);
    x
}

/// Runs `vertex(triangle, du, dv, height, pattern vertex, counters)` on the chunk-local
/// vertices `from..` of the chunk `out` that starts at embedding vertex `start`, one by one,
/// and stores each result with [`store`].
#[inline(always)]
pub(crate) fn each_vertex<T: Real>(
    e: &Embedding<T>,
    start: usize,
    from: usize,
    out: &mut [&mut [T]; 4],
    counters: &mut VertexCounters,
    vertex: impl Fn(u32, T, T, T, u32, &mut VertexCounters) -> ([T; 3], T),
) {
    for j in from..out[0].len() {
        let k = start + j;
        let (f, du, dv) = (e.triangle[k], e.du[k], e.dv[k]);
        let mapped = vertex(f, du, dv, e.height[k], e.tile_vertex[k], counters);
        store(out, j, mapped, counters);
    }
}

/// Writes vertex `j`'s mapped position and twist into the chunk `out` (`[x, y, z, twist]`), or
/// counts it as non-finite (leaving the previous output).
#[inline(always)]
pub(crate) fn store<T: Real>(
    out: &mut [&mut [T]; 4],
    j: usize,
    (x, t): ([T; 3], T),
    counters: &mut VertexCounters,
) {
    if x.iter().all(|c| c.is_finite()) && t.is_finite() {
        out[0][j] = x[0];
        out[1][j] = x[1];
        out[2][j] = x[2];
        out[3][j] = t;
    } else {
        counters.nonfinite_output += 1;
    }
}
