//! The GPU back end: the per-yarn-vertex stage as a WGSL compute shader (`deform.wgsl`) run
//! through wgpu; the mesh stage (faces, vertex averages, face polynomials) stays on the CPU
//! ([`Deformer::update_mesh`]) and is uploaded per frame (≈ 200 bytes per face).
//!
//! [`GpuDeformer::new`] picks any adapter wgpu finds (a real GPU, or Mesa's lavapipe /
//! llvmpipe CPU drivers) and fails with [`GpuError::NoAdapter`] otherwise, so callers can fall
//! back to the CPU ([`crate::backend::Backend::auto`]). Yarn data, the database and the per-pattern-vertex
//! tables are uploaded once; per frame the face polynomials and parameters are written, the
//! kernel dispatched, and the output read back. The read-back keeps a vertex's previous
//! output if the GPU produced a non-finite value, as the CPU back end does.
//!
//! The per-yarn-vertex arrays (inputs, heights, output, read-back) are split into chunks that
//! each fit the device's `max_storage_buffer_binding_size` and `max_buffer_size`, with one
//! dispatch per chunk whose workgroup grid respects `max_compute_workgroups_per_dimension`
//! ([`Chunking`]); the database, pattern tables and face buffer are shared by all chunks. Any
//! vertex count that fits host and device memory therefore runs; only the database and the
//! face buffer must each fit one binding ([`GpuError::TooLarge`]). All chunks are dispatched in
//! one submission and read back after one wait.
//!
//! Byte conversions use `to_le_bytes` (no `unsafe`); the upload/read-back buffers are reused
//! between frames.

use std::future::Future;
use std::sync::Arc;
use std::task::{Context, Poll, Wake};
use std::time::Instant;

use crate::deform::{Deformer, FrameStats, YarnOutput};
use crate::embed::Embedding;
use crate::mesh::{FACE_POLY_LEN, FacePoly};

/// Scalars per face in the GPU face buffer: the 48 of [`FacePoly`], the skip flag, padding.
pub const GPU_FACE_STRIDE: usize = 52;
const _: () = assert!(FACE_POLY_LEN + 4 == GPU_FACE_STRIDE);

const WORKGROUP: u32 = 64;
/// Bytes per yarn vertex of the largest per-vertex buffers (inputs and output: 4 × 32 bit).
const VERTEX_BYTES: u64 = 16;

/// How the per-vertex arrays are split into chunks and dispatched. The default adapts to the
/// device limits; smaller values exercise the chunked path in tests and benchmarks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Chunking {
    /// At most this many yarn vertices per chunk (≥ 1); further capped so that each chunk's
    /// buffers fit `max_storage_buffer_binding_size` and `max_buffer_size` and its dispatch
    /// fits the workgroup-count limit. Default: no cap beyond the device's.
    pub max_vertices: usize,
    /// At most this many workgroups (of 64 invocations) along x per dispatch (≥ 1); the rest
    /// goes along y. Further capped by `max_compute_workgroups_per_dimension`. Default 32768.
    pub row_groups: u32,
}

impl Default for Chunking {
    fn default() -> Self {
        Self {
            max_vertices: usize::MAX,
            row_groups: 32768,
        }
    }
}

/// Vertices per chunk and workgroups per dispatch row for `n` vertices under `limits`
/// (each chunk: `row · gy` workgroups with `row, gy ≤ max_compute_workgroups_per_dimension`).
fn plan_chunks(
    chunking: Chunking,
    max_binding: u64,
    max_groups_per_dimension: u32,
) -> Result<(usize, u32), GpuError> {
    if chunking.max_vertices == 0 || chunking.row_groups == 0 {
        return Err(GpuError::Chunking(format!(
            "expected at least one vertex per chunk and one workgroup per row, found {chunking:?}"
        )));
    }
    let row = chunking.row_groups.min(max_groups_per_dimension).max(1);
    let by_buffer = max_binding / VERTEX_BYTES;
    let by_dispatch =
        u64::from(row) * u64::from(max_groups_per_dimension.max(1)) * u64::from(WORKGROUP);
    // Chunk-local vertex indices are u32 in the shader.
    let by_index = 1u64 << 31;
    let per_chunk = by_buffer
        .min(by_dispatch)
        .min(by_index)
        .min(chunking.max_vertices as u64);
    if per_chunk == 0 {
        return Err(GpuError::TooLarge {
            name: "yarn vertex chunk",
            bytes: VERTEX_BYTES,
            limit: max_binding,
        });
    }
    Ok((per_chunk as usize, row))
}

/// One chunk of yarn vertices: its own inputs, output, read-back buffer, parameters and
/// bind group (the shader indexes chunk-locally).
struct Chunk {
    /// First yarn vertex of the chunk.
    start: usize,
    /// Yarn vertices in the chunk.
    len: usize,
    params: wgpu::Buffer,
    out: wgpu::Buffer,
    staging: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Workgroups along x and y.
    groups: (u32, u32),
}

pub use crate::error::GpuError;

/// Minimal executor for wgpu's futures (they complete after `device.poll`).
fn block_on<F: Future>(future: F) -> F::Output {
    struct ThreadWaker(std::thread::Thread);
    impl Wake for ThreadWaker {
        fn wake(self: Arc<Self>) {
            self.0.unpark();
        }
    }
    let waker = Arc::new(ThreadWaker(std::thread::current())).into();
    let mut cx = Context::from_waker(&waker);
    let mut future = std::pin::pin!(future);
    loop {
        match future.as_mut().poll(&mut cx) {
            Poll::Ready(v) => return v,
            Poll::Pending => std::thread::park(),
        }
    }
}

fn f32_bytes(values: impl IntoIterator<Item = f32>, out: &mut Vec<u8>) {
    out.clear();
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

fn face_scalars(p: &FacePoly<f32>, skip: u32) -> impl Iterator<Item = f32> + '_ {
    p.x0.iter()
        .chain(&p.xl)
        .chain(&p.xq)
        .chain(&p.n0)
        .chain(&p.nl)
        .chain(&p.i0)
        .chain(&p.il)
        .chain(&p.ii0)
        .chain(&p.iil)
        .chain(&p.nf)
        .copied()
        .chain([skip as f32, 0.0, 0.0, 0.0])
}

/// The GPU back end bound to one [`Deformer<f32>`]'s embedding and database.
pub struct GpuDeformer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::ComputePipeline,
    faces: wgpu::Buffer,
    chunks: Vec<Chunk>,
    n: usize,
    n_tile: usize,
    shape: [u32; 3],
    uniform: [Option<(f32, f32)>; 3],
    axes: [Vec<f32>; 3],
    bytes: Vec<u8>,
    output: YarnOutput<f32>,
    adapter: String,
    previous_input: Option<(Vec<[f64; 3]>, crate::deform::DeformOptions)>,
}

impl std::fmt::Debug for GpuDeformer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuDeformer")
            .field("adapter", &self.adapter)
            .field("vertices", &self.n)
            .field("chunks", &self.chunks.len())
            .finish()
    }
}

/// A storage buffer of at least `len` bytes (rounded up to 16, at least 16).
fn storage(
    device: &wgpu::Device,
    label: &str,
    len: usize,
    extra: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (len.max(16) as u64).div_ceil(16) * 16,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | extra,
        mapped_at_creation: false,
    })
}

/// A storage buffer holding `data`.
fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    data: &[u8],
    extra: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let buffer = storage(device, label, data.len(), extra);
    queue.write_buffer(&buffer, 0, data);
    buffer
}

/// Requests any adapter (high performance preferred) and a device with the adapter's own
/// limits: the device, its queue, the adapter description and the limits.
fn open_device() -> Result<(wgpu::Device, wgpu::Queue, String, wgpu::Limits), GpuError> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
    let adapter = block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: false,
        compatible_surface: None,
        apply_limit_buckets: false,
    }))
    .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
    let info = adapter.get_info();
    let adapter_name = format!("{} ({:?}, {:?})", info.name, info.device_type, info.backend);
    let limits = adapter.limits();
    let (device, queue) = block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("deform-runtime"),
        required_features: wgpu::Features::empty(),
        required_limits: limits.clone(),
        ..Default::default()
    }))
    .map_err(|e| GpuError::Device {
        adapter: adapter_name.clone(),
        message: e.to_string(),
    })?;
    Ok((device, queue, adapter_name, limits))
}

/// Checks that each buffer shared by all chunks (database, pattern tables, faces) fits one
/// binding of `max_binding` bytes.
fn check_shared_sizes(cpu: &Deformer<f32>, max_binding: u64) -> Result<(), GpuError> {
    let check = |name: &'static str, bytes: u64| {
        if bytes > max_binding {
            Err(GpuError::TooLarge {
                name,
                bytes,
                limit: max_binding,
            })
        } else {
            Ok(())
        }
    };
    check("texels", (cpu.database().texels().len() * 4) as u64)?;
    check(
        "pattern tables",
        (2 * cpu.database().n_vertices() * 16) as u64,
    )?;
    check("faces", (cpu.mesh().n_faces() * GPU_FACE_STRIDE * 4) as u64)
}

/// The buffers every chunk binds: the database texels and pattern tables (uploaded once)
/// and the face buffer (written per frame).
struct SharedBuffers {
    texels: wgpu::Buffer,
    tile_data: wgpu::Buffer,
    faces: wgpu::Buffer,
}

impl SharedBuffers {
    /// Uploads the database and the pattern tables (rest displacements, twists) of `cpu`
    /// and allocates the face buffer; `bytes` is scratch.
    fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        cpu: &Deformer<f32>,
        bytes: &mut Vec<u8>,
    ) -> Self {
        let none = wgpu::BufferUsages::empty();
        f32_bytes(cpu.database().texels_by_vertex(), bytes);
        let texels = upload(device, queue, "database", bytes, none);
        f32_bytes(
            cpu.rest_displacements()
                .iter()
                .flatten()
                .copied()
                .chain(cpu.twists().iter().flat_map(|&t| [t, 0.0, 0.0, 0.0])),
            bytes,
        );
        let tile_data = upload(device, queue, "pattern tables", bytes, none);
        let faces = storage(
            device,
            "faces",
            cpu.mesh().n_faces() * GPU_FACE_STRIDE * 4,
            none,
        );
        Self {
            texels,
            tile_data,
            faces,
        }
    }
}

/// The compute pipeline of `deform.wgsl`.
fn deform_pipeline(device: &wgpu::Device) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("deform.wgsl"),
        source: wgpu::ShaderSource::Wgsl(include_str!("deform.wgsl").into()),
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("deform"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// What every chunk of one [`GpuDeformer`] is built from.
struct ChunkBuilder<'a> {
    device: &'a wgpu::Device,
    queue: &'a wgpu::Queue,
    layout: &'a wgpu::BindGroupLayout,
    shared: &'a SharedBuffers,
    embedding: &'a Embedding<f32>,
    /// Workgroups per dispatch row.
    row: u32,
}

impl ChunkBuilder<'_> {
    /// Splits the yarn vertices into consecutive chunks of at most `per_chunk` vertices;
    /// `bytes` is scratch.
    fn chunks(&self, per_chunk: usize, bytes: &mut Vec<u8>) -> Vec<Chunk> {
        let n = self.embedding.len();
        let mut chunks = Vec::with_capacity(n.div_ceil(per_chunk));
        let mut start = 0;
        while start < n {
            let len = per_chunk.min(n - start);
            chunks.push(self.chunk(start, len, bytes));
            start += len;
        }
        chunks
    }

    /// Uploads the inputs of yarn vertices `start..start + len` and creates the chunk's
    /// output, read-back and parameter buffers, its bind group and its dispatch grid.
    fn chunk(&self, start: usize, len: usize, bytes: &mut Vec<u8>) -> Chunk {
        let (device, e) = (self.device, self.embedding);
        let range = start..start + len;
        bytes.clear();
        for k in range.clone() {
            for word in [
                e.triangle[k],
                e.tile_vertex[k],
                e.du[k].to_bits(),
                e.dv[k].to_bits(),
            ] {
                bytes.extend_from_slice(&word.to_le_bytes());
            }
        }
        let none = wgpu::BufferUsages::empty();
        let vin = upload(device, self.queue, "yarn vertices", bytes, none);
        f32_bytes(e.height[range].iter().copied(), bytes);
        let vheight = upload(device, self.queue, "yarn heights", bytes, none);
        let out = storage(
            device,
            "output",
            len * VERTEX_BYTES as usize,
            wgpu::BufferUsages::COPY_SRC,
        );
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read-back"),
            size: out.size(),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: PARAMS_BYTES as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let shared = self.shared;
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("deform"),
            layout: self.layout,
            entries: &[
                (0, &params),
                (1, &vin),
                (2, &vheight),
                (3, &shared.texels),
                (4, &shared.tile_data),
                (5, &shared.faces),
                (6, &out),
            ]
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            }),
        });
        // `plan_chunks` bounds `len` so that the y count fits the dimension limit.
        let groups = (len as u64).div_ceil(u64::from(WORKGROUP));
        let gx = groups.min(u64::from(self.row)) as u32;
        let gy = groups.div_ceil(u64::from(self.row)) as u32;
        Chunk {
            start,
            len,
            params,
            out,
            staging,
            bind_group,
            groups: (gx, gy),
        }
    }
}

impl GpuDeformer {
    /// Requests an adapter and device and uploads the static data of `cpu`, with the
    /// per-vertex arrays split into chunks that fit the device limits.
    pub fn new(cpu: &Deformer<f32>) -> Result<Self, GpuError> {
        Self::with_chunking(cpu, Chunking::default())
    }

    /// As [`GpuDeformer::new`], with explicit (smaller) chunks: results do not depend on the
    /// chunking; tests and benchmarks use it to exercise the split.
    pub fn with_chunking(cpu: &Deformer<f32>, chunking: Chunking) -> Result<Self, GpuError> {
        let (device, queue, adapter_name, limits) = open_device()?;
        let db = cpu.database();
        let max_binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        check_shared_sizes(cpu, max_binding)?;
        let (per_chunk, row) = plan_chunks(
            chunking,
            max_binding,
            limits.max_compute_workgroups_per_dimension,
        )?;

        let mut bytes = Vec::new();
        let shared = SharedBuffers::new(&device, &queue, cpu, &mut bytes);
        let pipeline = deform_pipeline(&device);
        let layout = pipeline.get_bind_group_layout(0);
        let chunks = ChunkBuilder {
            device: &device,
            queue: &queue,
            layout: &layout,
            shared: &shared,
            embedding: cpu.embedding(),
            row,
        }
        .chunks(per_chunk, &mut bytes);
        let [sx, sa, sy] = db.shape();
        Ok(Self {
            device,
            queue,
            pipeline,
            faces: shared.faces,
            chunks,
            n: cpu.embedding().len(),
            n_tile: db.n_vertices(),
            shape: [sx as u32, sa as u32, sy as u32],
            uniform: db.uniform_axes(),
            axes: [0, 1, 2].map(|k| db.axis(k).to_vec()),
            bytes,
            output: cpu.output().clone(),
            adapter: adapter_name,
            previous_input: None,
        })
    }

    /// Adapter description (name, type, backend).
    pub fn adapter(&self) -> &str {
        &self.adapter
    }

    /// The output of the last frame.
    pub fn output(&self) -> &YarnOutput<f32> {
        &self.output
    }

    /// Yarn vertices per chunk, in order (one dispatch each).
    pub fn chunk_lengths(&self) -> Vec<usize> {
        self.chunks.iter().map(|c| c.len).collect()
    }

    /// Runs one frame: the mesh stage on the CPU (through `cpu`), the vertex stage on the GPU.
    /// `vertex_seconds` includes upload, dispatch and read-back.
    /// With [`crate::DeformOptions::skip_static`], a frame whose positions and options equal
    /// the previous frame's reuses the previous output.
    pub fn frame(
        &mut self,
        cpu: &mut Deformer<f32>,
        positions: &[[f64; 3]],
    ) -> Result<FrameStats, GpuError> {
        let options = *cpu.options();
        if options.skip_static
            && let Some((previous, previous_options)) = &self.previous_input
            && *previous_options == options
            && previous.len() == positions.len()
            && previous
                .iter()
                .zip(positions)
                .all(|(a, b)| a.map(f64::to_bits) == b.map(f64::to_bits))
        {
            return Ok(FrameStats {
                static_frame: true,
                ..FrameStats::default()
            });
        }
        match &mut self.previous_input {
            Some((previous, previous_options)) => {
                previous.clear();
                previous.extend_from_slice(positions);
                *previous_options = options;
            }
            None => self.previous_input = Some((positions.to_vec(), options)),
        }
        let t0 = Instant::now();
        let mesh = cpu.update_mesh(positions)?;
        let t1 = Instant::now();
        let o = options;
        let g = cpu.geometry();
        self.bytes.clear();
        for (p, &skip) in g.face_poly.iter().zip(&g.face_skip) {
            for v in face_scalars(p, skip) {
                self.bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        debug_assert_eq!(self.bytes.len(), g.face_poly.len() * GPU_FACE_STRIDE * 4);
        self.queue.write_buffer(&self.faces, 0, &self.bytes);
        let flags = u32::from(o.displacement)
            | (u32::from(o.linearized_bending) << 1)
            | (u32::from(o.skip_identity) << 2);
        self.write_params(flags, cpu.eigen_floor());
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("deform"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("deform"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            for chunk in &self.chunks {
                pass.set_bind_group(0, &chunk.bind_group, &[]);
                pass.dispatch_workgroups(chunk.groups.0, chunk.groups.1, 1);
            }
        }
        for chunk in &self.chunks {
            encoder.copy_buffer_to_buffer(&chunk.out, 0, &chunk.staging, 0, chunk.out.size());
        }
        self.queue.submit([encoder.finish()]);
        let (sender, receiver) = std::sync::mpsc::channel();
        for chunk in &self.chunks {
            let sender = sender.clone();
            chunk
                .staging
                .slice(..)
                .map_async(wgpu::MapMode::Read, move |r| {
                    sender.send(r).ok();
                });
        }
        drop(sender);
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        for _ in &self.chunks {
            receiver
                .recv()
                .map_err(|e| GpuError::Readback(e.to_string()))?
                .map_err(|e| GpuError::Readback(e.to_string()))?;
        }
        let mut nonfinite = 0;
        let out = &mut self.output;
        for chunk in &self.chunks {
            {
                let view = chunk
                    .staging
                    .slice(..)
                    .get_mapped_range()
                    .map_err(|e| GpuError::Readback(e.to_string()))?;
                for (j, bytes) in view.chunks_exact(16).take(chunk.len).enumerate() {
                    let k = chunk.start + j;
                    let v = [0, 4, 8, 12].map(|o| {
                        f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]])
                    });
                    if v.iter().all(|x| x.is_finite()) {
                        out.x[k] = v[0];
                        out.y[k] = v[1];
                        out.z[k] = v[2];
                        out.twist[k] = v[3];
                    } else {
                        nonfinite += 1;
                    }
                }
            }
            chunk.staging.unmap();
        }
        let t2 = Instant::now();
        let mut stats = FrameStats {
            static_frame: false,
            mesh,
            mesh_seconds: (t1 - t0).as_secs_f64(),
            vertex_seconds: (t2 - t1).as_secs_f64(),
            ..FrameStats::default()
        };
        stats.vertices.processed = self.n;
        stats.vertices.nonfinite_output = nonfinite;
        Ok(stats)
    }

    /// Writes each chunk's parameters: the shared ones and the chunk's vertex count and
    /// dispatch row length.
    fn write_params(&mut self, flags: u32, eigen_floor: f32) {
        let mut words: Vec<u32> = Vec::with_capacity(PARAMS_BYTES / 4);
        words.extend([0, flags, self.n_tile as u32, eigen_floor.to_bits()]);
        words.extend([self.shape[0], self.shape[1], self.shape[2], 0]);
        let uni = self.uniform.map(|u| u.unwrap_or((0.0, 0.0)));
        words.extend(uni.iter().map(|u| u.0.to_bits()).chain([0]));
        words.extend(uni.iter().map(|u| u.1.to_bits()).chain([0]));
        for axis in &self.axes {
            let mut padded = [0u32; 32];
            for (j, v) in axis.iter().enumerate().take(32) {
                padded[j] = v.to_bits();
            }
            words.extend(padded);
        }
        for chunk in &self.chunks {
            words[0] = chunk.len as u32;
            words[7] = chunk.groups.0 * WORKGROUP;
            self.bytes.clear();
            for w in &words {
                self.bytes.extend_from_slice(&w.to_le_bytes());
            }
            self.queue.write_buffer(&chunk.params, 0, &self.bytes);
        }
    }
}

/// Size of the `Params` uniform: 4 vec4 + 24 vec4 of axes.
const PARAMS_BYTES: usize = (4 + 24) * 16;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_fit_buffer_and_dispatch_limits() {
        // wgpu's default limits: 128 MiB bindings, 65535 workgroups per dimension.
        let (per_chunk, row) = plan_chunks(Chunking::default(), 128 << 20, 65535).unwrap();
        assert_eq!((per_chunk, row), (8 << 20, 32768));
        // 4 GiB bindings: 256 M vertices; 64 GiB would exceed the u32 index range.
        let (per_chunk, _) = plan_chunks(Chunking::default(), 4 << 30, 65535).unwrap();
        assert_eq!(per_chunk, 1 << 28);
        let (per_chunk, _) = plan_chunks(Chunking::default(), 64 << 30, 65535).unwrap();
        assert_eq!(per_chunk, 1 << 31);
        // Few workgroups per dimension: rows shrink and a chunk holds at most row² groups.
        let (per_chunk, row) = plan_chunks(Chunking::default(), 128 << 20, 4).unwrap();
        assert_eq!((per_chunk, row), (4 * 4 * 64, 4));
        // Explicit caps win when smaller.
        let tiny = Chunking {
            max_vertices: 37,
            row_groups: 2,
        };
        assert_eq!(plan_chunks(tiny, 128 << 20, 65535).unwrap(), (37, 2));
        assert!(matches!(
            plan_chunks(
                Chunking {
                    max_vertices: 0,
                    ..tiny
                },
                128 << 20,
                65535
            ),
            Err(GpuError::Chunking(_))
        ));
        assert!(matches!(
            plan_chunks(Chunking::default(), 15, 65535),
            Err(GpuError::TooLarge { .. })
        ));
    }
}

/// Largest coordinate difference between two outputs relative to the largest coordinate
/// magnitude of `a`, and largest twist difference (rad): the CPU/GPU agreement measure.
pub fn agreement(a: &YarnOutput<f32>, b: &YarnOutput<f32>) -> (f64, f64) {
    let scale =
        a.x.iter()
            .chain(&a.y)
            .chain(&a.z)
            .fold(0.0f64, |m, &v| m.max(f64::from(v).abs()));
    let mut worst = 0.0f64;
    let mut worst_twist = 0.0f64;
    for k in 0..a.x.len() {
        for (p, q) in [(a.x[k], b.x[k]), (a.y[k], b.y[k]), (a.z[k], b.z[k])] {
            worst = worst.max(f64::from(p - q).abs() / scale);
        }
        worst_twist = worst_twist.max(f64::from(a.twist[k] - b.twist[k]).abs());
    }
    (worst, worst_twist)
}

/// What [`benchmark`] measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct GpuBenchmark {
    /// Adapter description.
    pub adapter: String,
    /// Yarn vertices per frame.
    pub vertices: usize,
    /// GPU dispatches per frame (chunks).
    pub chunks: usize,
    /// Best GPU frame (s): CPU mesh stage, face upload, dispatches and read-back.
    pub gpu_frame_seconds: f64,
    /// Best GPU vertex stage (s): face upload, dispatches and read-back.
    pub gpu_vertex_seconds: f64,
    /// Best CPU frame (s) of the same frame.
    pub cpu_frame_seconds: f64,
    /// [`agreement`] of the CPU and GPU outputs: relative coordinate difference.
    pub max_relative_difference: f64,
    /// [`agreement`]: twist difference (rad).
    pub max_twist_difference: f64,
}

/// Times the full frame of `scene` on the GPU and the CPU (best of `frames` after one warm-up
/// frame each, static-frame skipping off) and compares their outputs.
pub fn benchmark(
    scene: &mut crate::synthetic::ThroughputScene<f32>,
    frames: usize,
) -> Result<GpuBenchmark, GpuError> {
    let cpu = &mut scene.deformer;
    cpu.set_options(crate::DeformOptions {
        skip_static: false,
        ..*cpu.options()
    })?;
    let mut gpu = GpuDeformer::new(cpu)?;
    let frames = frames.max(1);
    let best = |f: &mut dyn FnMut() -> Result<FrameStats, GpuError>| {
        f()?;
        let mut best = (f64::INFINITY, f64::INFINITY);
        for _ in 0..frames {
            let s = f()?;
            best.0 = best.0.min(s.mesh_seconds + s.vertex_seconds);
            best.1 = best.1.min(s.vertex_seconds);
        }
        Ok::<_, GpuError>(best)
    };
    let moved = &scene.moved;
    let (gpu_frame, gpu_vertex) = best(&mut || gpu.frame(cpu, moved))?;
    let (cpu_frame, _) = best(&mut || Ok(cpu.frame(moved)?))?;
    let (relative, twist) = agreement(cpu.output(), gpu.output());
    Ok(GpuBenchmark {
        adapter: gpu.adapter().to_string(),
        vertices: cpu.embedding().len(),
        chunks: gpu.chunk_lengths().len(),
        gpu_frame_seconds: gpu_frame,
        gpu_vertex_seconds: gpu_vertex,
        cpu_frame_seconds: cpu_frame,
        max_relative_difference: relative,
        max_twist_difference: twist,
    })
}
