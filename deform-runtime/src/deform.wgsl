// Per-yarn-vertex stage of paper 004 Algorithm 1 (lines 7-13), the WGSL twin of
// `deform::deform_vertex`: interpolate I and II, linearized bending, compression clamping,
// strains, trilinear database lookup with nearest-sample clamping, displacement and the
// world mapping through the per-face polynomials (see `mesh::FacePoly`).

struct Params {
    n: u32,              // yarn vertices
    flags: u32,          // 1: displacement, 2: linearized bending, 4: skip identity faces
    n_tile: u32,         // pattern vertices
    eigen_floor: f32,    // λmin (or the safety floor)
    shape: vec4<u32>,    // |SX|, |SA|, |SY|, dispatch row length (invocations per y)
    uni_a0: vec4<f32>,   // first sample of uniform axes
    uni_inv: vec4<f32>,  // 1 / spacing of uniform axes, 0 for non-uniform axes
    axes: array<vec4<f32>, 24>, // sample j of axis k at scalar index 32 k + j
}

const FACE_STRIDE: u32 = 52u;

@group(0) @binding(0) var<uniform> P: Params;
// (triangle, pattern vertex, bits of du, bits of dv)
@group(0) @binding(1) var<storage, read> vin: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read> vheight: array<f32>;
@group(0) @binding(3) var<storage, read> texels: array<f32>;
// [0, n_tile): zero-strain displacement; [n_tile, 2 n_tile): (rest twist, 0, 0, 0)
@group(0) @binding(4) var<storage, read> tile_data: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> faces: array<f32>;
@group(0) @binding(6) var<storage, read_write> out: array<vec4<f32>>;

struct AxisWeight {
    lo: u32,
    hi: u32,
    t: f32,
}

fn axis_value(k: u32, j: u32) -> f32 {
    let i = 32u * k + j;
    return P.axes[i / 4u][i % 4u];
}

fn locate(k: u32, s: f32) -> AxisWeight {
    let n = P.shape[k];
    if (n < 2u) {
        return AxisWeight(0u, 0u, 0.0);
    }
    let inv = P.uni_inv[k];
    if (inv > 0.0) {
        let t = clamp((s - P.uni_a0[k]) * inv, 0.0, f32(n - 1u));
        let lo = min(u32(t), n - 2u);
        return AxisWeight(lo, lo + 1u, t - f32(lo));
    }
    if (!(s > axis_value(k, 0u))) {
        return AxisWeight(0u, 1u, 0.0);
    }
    if (s >= axis_value(k, n - 1u)) {
        return AxisWeight(n - 2u, n - 1u, 1.0);
    }
    var j = 0u;
    loop {
        if (j + 2u >= n || axis_value(k, j + 1u) > s) {
            break;
        }
        j = j + 1u;
    }
    let a = axis_value(k, j);
    let b = axis_value(k, j + 1u);
    return AxisWeight(j, j + 1u, (s - a) / (b - a));
}

fn face3(base: u32, o: u32) -> vec3<f32> {
    return vec3<f32>(faces[base + o], faces[base + o + 1u], faces[base + o + 2u]);
}

fn clamp_eigenvalues(i: vec3<f32>, lo: f32) -> vec3<f32> {
    let m = 0.5 * (i.x + i.z);
    let h = 0.5 * (i.x - i.z);
    let d = sqrt(h * h + i.y * i.y);
    let l2 = m - d;
    if (l2 >= lo) {
        return i;
    }
    let l1 = max(m + d, lo);
    if (d > 0.0) {
        let inv = 1.0 / (d + d);
        let k = l1 - lo;
        return vec3<f32>(lo + k * ((i.x - l2) * inv), k * (i.y * inv), lo + k * ((i.z - l2) * inv));
    }
    return vec3<f32>(lo, 0.0, lo);
}

// Sample- and component-major database (`RuntimeDatabase::index`): component c of sample r
// of pattern vertex v at (4 r + c) n_tile + v.
fn texel(r: u32, v: u32) -> vec4<f32> {
    let base = 4u * r * P.n_tile + v;
    return vec4<f32>(
        texels[base],
        texels[base + P.n_tile],
        texels[base + 2u * P.n_tile],
        texels[base + 3u * P.n_tile],
    );
}

fn lookup(tv: u32, s: vec3<f32>) -> vec4<f32> {
    let wx = locate(0u, s.x);
    let wa = locate(1u, s.y);
    let wy = locate(2u, s.z);
    let nx = P.shape.x;
    let na = P.shape.y;
    var acc = vec4<f32>(0.0);
    let ia = array<u32, 4>(wa.lo, wa.hi, wa.lo, wa.hi);
    let iy = array<u32, 4>(wy.lo, wy.lo, wy.hi, wy.hi);
    let w = array<f32, 4>(
        (1.0 - wa.t) * (1.0 - wy.t),
        wa.t * (1.0 - wy.t),
        (1.0 - wa.t) * wy.t,
        wa.t * wy.t,
    );
    for (var c = 0u; c < 4u; c = c + 1u) {
        let row = nx * (ia[c] + na * iy[c]);
        let a = texel(row + wx.lo, tv);
        let b = texel(row + wx.hi, tv);
        acc = acc + w[c] * ((1.0 - wx.t) * a + wx.t * b);
    }
    return acc;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x + gid.y * P.shape.w;
    if (k >= P.n) {
        return;
    }
    let a = vin[k];
    let f = a.x;
    let tv = a.y;
    let du = bitcast<f32>(a.z);
    let dv = bitcast<f32>(a.w);
    let height = vheight[k];
    let base = f * FACE_STRIDE;
    var dq = vec4<f32>(0.0);
    if ((P.flags & 1u) != 0u) {
        if ((P.flags & 4u) != 0u && faces[base + 48u] != 0.0) {
            dq = tile_data[tv];
        } else {
            var i = face3(base, 27u) + face3(base, 30u) * du + face3(base, 33u) * dv;
            if ((P.flags & 2u) != 0u) {
                let ii = face3(base, 36u) + face3(base, 39u) * du + face3(base, 42u) * dv;
                i = i - (height + height) * ii;
            }
            i = clamp_eigenvalues(i, P.eigen_floor);
            let a11 = sqrt(i.x);
            let a22 = sqrt(i.z);
            dq = lookup(tv, vec3<f32>(a11 - 1.0, i.y / (a11 * a22), a22 - 1.0));
        }
    }
    let u = du + dq.x;
    let v = dv + dq.y;
    let h = height + dq.z;
    var x = face3(base, 0u) + face3(base, 3u) * u + face3(base, 6u) * v
        + face3(base, 9u) * (u * u) + face3(base, 12u) * (u * v) + face3(base, 15u) * (v * v);
    var n = face3(base, 18u) + face3(base, 21u) * u + face3(base, 24u) * v;
    let len2 = dot(n, n);
    if (len2 > 0.0) {
        n = n * (1.0 / sqrt(len2));
    } else {
        n = face3(base, 45u);
    }
    x = x + h * n;
    out[k] = vec4<f32>(x, tile_data[P.n_tile + tv].x + dq.w);
}
