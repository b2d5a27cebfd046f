//! How fast the per-vertex stage could run on this machine: the bytes and operations each
//! yarn vertex costs, the machine's memory bandwidth and arithmetic rate measured in the same
//! run, and the throughput those two roofs allow (Williams et al., *Roofline*, CACM 2009).
//!
//! - **Bytes** ([`VertexCost::dram_bytes`]): what each vertex must stream from and to memory
//!   at ≥ 10 M vertices, where no per-vertex array fits in cache: the embedding's triangle,
//!   `du`, `dv`, height and pattern vertex (5 × 4 bytes in `f32`), and the output `x, y, z, θ`
//!   (4 × 4 bytes written, plus 4 × 4 bytes read since a store first reads its cache line:
//!   write-allocate). The face polynomials and the database are shared by many vertices and
//!   stay in cache; they are listed apart ([`VertexCost::cache_bytes`]).
//! - **Operations** ([`VertexCost::ops`]): the arithmetic of [`crate::lanes`] per vertex,
//!   counted from its source (additions and multiplications, square roots, divisions; selects,
//!   comparisons and conversions are not counted).
//! - **Bandwidth** ([`triad_bandwidth`]): a STREAM-like triad `a = b + s·c` in `f32` over
//!   arrays far larger than the caches, on every rayon thread, counting the same write-allocate
//!   traffic as the vertex count does (16 bytes per element), best of several runs.
//! - **Arithmetic rate** ([`mix_rate`]): the vertex stage's operation mix executed from
//!   registers in eight-lane vectors with enough independent chains to hide latencies,
//!   dispatched to the same instruction set as the kernel (`pulp`), on every rayon thread:
//!   yarn vertices per second if the kernel did only its arithmetic.
//!
//! The roof is the lower of `bandwidth / dram_bytes` and the arithmetic rate; a measured
//! throughput is reported as a fraction of it ([`Roofline::fraction`]).

use std::hint::black_box;
use std::time::Instant;

use rayon::prelude::*;

/// MADYPG's GPU runtime, the paper's reference throughput (paper 004 Table 1: 42.7 M yarn
/// vertices in 63 ms on a GTX 1080 Ti), in yarn vertices per second.
pub const MADYPG_GPU_VERTICES_PER_SECOND: f64 = 42.7e6 / 0.063;

/// Operation counts of one yarn vertex (full pipeline: displacement, linearized bending,
/// clamping, interpolated forms, Phong), by kind.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct OpMix {
    /// Multiplications.
    pub mul: u32,
    /// Additions and subtractions.
    pub add: u32,
    /// Square roots.
    pub sqrt: u32,
    /// Divisions.
    pub div: u32,
}

impl OpMix {
    /// All counted operations.
    pub fn total(&self) -> u32 {
        self.mul + self.add + self.sqrt + self.div
    }
}

/// One stage of the per-vertex work with its traffic and arithmetic.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct StageCost {
    /// Stage name.
    pub name: &'static str,
    /// Bytes streamed from or to memory per vertex.
    pub dram_bytes: u32,
    /// Bytes read from cache-resident shared data (faces, database) per vertex.
    pub cache_bytes: u32,
    /// Arithmetic per vertex.
    pub ops: OpMix,
}

/// The cost of one yarn vertex of the `f32` per-vertex stage, by stage (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct VertexCost {
    /// Strains: interpolated `I` and `II`, `I(h)`, eigenvalue clamping, `(sx, sa, sy)`.
    pub strains: StageCost,
    /// Lookup: axis weights and the trilinear blend of eight texels.
    pub lookup: StageCost,
    /// Map: displaced point through the Phong map and the normal, twist, store.
    pub map: StageCost,
}

/// Bytes of one `f32`.
const F32: u32 = 4;

impl VertexCost {
    /// The counts of the `f32` kernel in [`crate::lanes`].
    pub fn f32_kernel() -> Self {
        Self {
            strains: StageCost {
                name: "strains",
                // triangle, du, dv, height
                dram_bytes: 4 * F32,
                // I0, ∂I, II0, ∂II of the face (broadcast per batch; per lane at boundaries)
                cache_bytes: 0,
                ops: OpMix {
                    // I: 3 × (2 mul, 2 add); I(h): 1 add + 3 × (3 mul, 3 add);
                    // clamping: 10 mul, 11 add, 1 sqrt, 1 div; strains: 1 mul, 2 add, 2 sqrt,
                    // 1 div.
                    mul: 6 + 9 + 10 + 1,
                    add: 6 + 10 + 11 + 2,
                    sqrt: 3,
                    div: 2,
                },
            },
            lookup: StageCost {
                name: "lookup",
                // pattern vertex
                dram_bytes: F32,
                // eight texels (Δx, Δy, Δz, Δθ) and the zero-strain displacement
                cache_bytes: 9 * 4 * F32,
                ops: OpMix {
                    // weights: 3 × (1 mul, 1 sub) + 3 sub + 4 mul; blend: 4 pairs × 4
                    // components × (3 mul, 2 add).
                    mul: 3 + 4 + 48,
                    add: 3 + 3 + 32,
                    sqrt: 0,
                    div: 0,
                },
            },
            map: StageCost {
                name: "map",
                // x, y, z, θ written, and read by write-allocate
                dram_bytes: 2 * 4 * F32,
                // the rest twist
                cache_bytes: F32,
                ops: OpMix {
                    // u, v, h: 3 add; quadratic terms 3 mul; φ: 3 × (5 mul, 5 add); n: 3 ×
                    // (2 mul, 2 add); |n|²: 3 mul, 2 add; 1 sqrt, 1 div; x + h n: 3 × (2 mul,
                    // 1 add); θ: 1 add.
                    mul: 3 + 15 + 6 + 3 + 6,
                    add: 3 + 15 + 6 + 2 + 3 + 1,
                    sqrt: 1,
                    div: 1,
                },
            },
        }
    }

    /// The stages in pipeline order.
    pub fn stages(&self) -> [StageCost; 3] {
        [self.strains, self.lookup, self.map]
    }

    /// Bytes per vertex streamed from or to memory.
    pub fn dram_bytes(&self) -> u32 {
        self.stages().iter().map(|s| s.dram_bytes).sum()
    }

    /// Bytes per vertex read from cache-resident shared data.
    pub fn cache_bytes(&self) -> u32 {
        self.stages().iter().map(|s| s.cache_bytes).sum()
    }

    /// Operations per vertex.
    pub fn ops(&self) -> OpMix {
        self.stages().iter().fold(
            OpMix {
                mul: 0,
                add: 0,
                sqrt: 0,
                div: 0,
            },
            |a, s| OpMix {
                mul: a.mul + s.ops.mul,
                add: a.add + s.ops.add,
                sqrt: a.sqrt + s.ops.sqrt,
                div: a.div + s.ops.div,
            },
        )
    }
}

/// The two roofs measured on this machine and the vertex cost they apply to.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Roofline {
    /// Triad bandwidth (bytes/s) on every rayon thread.
    pub bandwidth: f64,
    /// Yarn vertices per second that the arithmetic alone allows on every rayon thread.
    pub arithmetic: f64,
    /// The vertex cost.
    pub cost: VertexCost,
    /// rayon threads of both measurements.
    pub threads: usize,
}

impl Roofline {
    /// Measures both roofs for `cost` (a few seconds).
    pub fn measure(cost: VertexCost) -> Self {
        Self {
            bandwidth: triad_bandwidth(1 << 25, 5),
            arithmetic: mix_rate(cost.ops(), 1 << 16, 5),
            cost,
            threads: rayon::current_num_threads(),
        }
    }

    /// Yarn vertices per second that the bandwidth allows.
    pub fn memory(&self) -> f64 {
        self.bandwidth / f64::from(self.cost.dram_bytes())
    }

    /// The lower roof (yarn vertices per second).
    pub fn roof(&self) -> f64 {
        self.memory().min(self.arithmetic)
    }

    /// Which roof is lower: `"memory"` or `"arithmetic"`.
    pub fn bound(&self) -> &'static str {
        if self.memory() <= self.arithmetic {
            "memory"
        } else {
            "arithmetic"
        }
    }

    /// `vertices_per_second` as a fraction of the lower roof.
    pub fn fraction(&self, vertices_per_second: f64) -> f64 {
        vertices_per_second / self.roof()
    }
}

impl std::fmt::Display for Roofline {
    /// One line: both roofs with what they rest on, and the lower one.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "triad {:.1} GB/s over {} B/vertex = {:.0} M vertices/s; arithmetic ({} ops/vertex) \
             {:.0} M vertices/s; lower roof {:.0} M vertices/s ({}-bound, {} threads)",
            self.bandwidth / 1e9,
            self.cost.dram_bytes(),
            self.memory() / 1e6,
            self.cost.ops().total(),
            self.arithmetic / 1e6,
            self.roof() / 1e6,
            self.bound(),
            self.threads
        )
    }
}

/// Triad bandwidth (bytes/s): `a[i] = b[i] + 0.5 c[i]` over three `f32` arrays of `len`
/// elements on every rayon thread, counting 16 bytes per element (read `b` and `c`, write `a`
/// and its write-allocate read), best of `runs`.
pub fn triad_bandwidth(len: usize, runs: usize) -> f64 {
    let b: Vec<f32> = (0..len).map(|i| (i % 7) as f32).collect();
    let c: Vec<f32> = (0..len).map(|i| (i % 5) as f32).collect();
    let mut a = vec![0.0f32; len];
    let chunk = len.div_ceil(4 * rayon::current_num_threads().max(1)).max(1);
    let mut best = f64::INFINITY;
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        a.par_chunks_mut(chunk)
            .zip(b.par_chunks(chunk).zip(c.par_chunks(chunk)))
            .for_each(|(a, (b, c))| {
                for ((a, b), c) in a.iter_mut().zip(b).zip(c) {
                    *a = b + 0.5 * c;
                }
            });
        best = best.min(t.elapsed().as_secs_f64());
        black_box(&a);
    }
    16.0 * len as f64 / best
}

/// Independent vector chains of the arithmetic measurement: enough to cover the latency of
/// the multiply–add pairs at four vector operations per cycle, few enough to stay in the 16
/// vector registers of x86-64.
const CHAINS: usize = 12;
/// Lanes of one vector of the arithmetic measurement: one AVX2 register of `f32`, the width
/// the kernel runs at on x86-64.
const WIDTH: usize = 8;

/// Yarn vertices per second that the arithmetic `mix` allows: `batches` batches of
/// 12 × 8 vertices (one lane each of 12 independent eight-lane `f32` vectors in registers,
/// enough to hide the latency of the multiply–add pairs), each batch executing `mix` once per
/// vertex, on every rayon thread, best of `runs`.
pub fn mix_rate(mix: OpMix, batches: usize, runs: usize) -> f64 {
    let threads = rayon::current_num_threads().max(1);
    let mut best = f64::INFINITY;
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        let sum: f32 = (0..threads)
            .into_par_iter()
            .map(|seed| pulp::Arch::new().dispatch(Mix { mix, batches, seed }))
            .sum();
        best = best.min(t.elapsed().as_secs_f64());
        black_box(sum);
    }
    (threads * batches * CHAINS * WIDTH) as f64 / best
}

/// One thread of [`mix_rate`], compiled for the instruction set `pulp` selects.
struct Mix {
    mix: OpMix,
    batches: usize,
    seed: usize,
}

impl pulp::WithSimd for Mix {
    type Output = f32;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> f32 {
        let Mix { mix, batches, seed } = self;
        let rounds = |n: u32| n as usize;
        // Multiplications and additions are issued in pairs `x·m + a` (unfused, like the
        // kernel); the surplus of one kind alone.
        let pairs = rounds(mix.mul.min(mix.add));
        let extra_mul = rounds(mix.mul.saturating_sub(mix.add));
        let extra_add = rounds(mix.add.saturating_sub(mix.mul));
        let (sqrts, divs) = (rounds(mix.sqrt), rounds(mix.div));
        let start = black_box(1.0 + seed as f32 * 1e-3);
        let mut x = [[start; WIDTH]; CHAINS];
        let mut y = [[start; WIDTH]; CHAINS];
        let (m, a) = (black_box(0.5f32), black_box(1.0f32));
        let batches = black_box(batches);
        for _ in 0..batches {
            // x stays near 2 under x·m + a, and y near 1 under √y and a / y: every value
            // stays normal.
            for _ in 0..pairs {
                for c in 0..CHAINS {
                    for l in 0..WIDTH {
                        x[c][l] = x[c][l] * m + a;
                    }
                }
            }
            for _ in 0..extra_mul {
                for c in 0..CHAINS {
                    for l in 0..WIDTH {
                        x[c][l] *= m;
                    }
                }
            }
            for _ in 0..extra_add {
                for c in 0..CHAINS {
                    for l in 0..WIDTH {
                        x[c][l] += a;
                    }
                }
            }
            for _ in 0..sqrts {
                for c in 0..CHAINS {
                    for l in 0..WIDTH {
                        y[c][l] = y[c][l].sqrt();
                    }
                }
            }
            for _ in 0..divs {
                for c in 0..CHAINS {
                    for l in 0..WIDTH {
                        y[c][l] = a / y[c][l];
                    }
                }
            }
        }
        x.iter().chain(&y).flatten().sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measurements_are_finite_and_positive() {
        let bw = triad_bandwidth(1 << 16, 2);
        assert!(bw.is_finite() && bw > 0.0);
        let rate = mix_rate(VertexCost::f32_kernel().ops(), 64, 2);
        assert!(rate.is_finite() && rate > 0.0);
    }
}
