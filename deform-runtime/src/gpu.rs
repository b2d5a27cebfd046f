//! The GPU back end: the per-yarn-vertex stage as a WGSL compute shader (`deform.wgsl`) run
//! through wgpu; the mesh stage (faces, vertex averages, face polynomials) stays on the CPU
//! ([`Deformer::update_mesh`]) and is uploaded per frame (≈ 200 bytes per face).
//!
//! [`GpuDeformer::new`] picks any adapter wgpu finds (a real GPU, or Mesa's lavapipe /
//! llvmpipe CPU drivers) and fails with [`GpuError::NoAdapter`] otherwise, so callers can fall
//! back to the CPU ([`Backend::auto`]). Yarn data, the database and the per-pattern-vertex
//! tables are uploaded once; per frame the face polynomials and parameters are written, the
//! kernel dispatched, and the output read back. The read-back keeps a vertex's previous
//! output if the GPU produced a non-finite value, as the CPU back end does.
//!
//! Byte conversions use `to_le_bytes` (no `unsafe`); the upload/read-back buffers are reused
//! between frames.

use std::future::Future;
use std::sync::Arc;
use std::task::{Context, Poll, Wake};
use std::time::Instant;

use crate::deform::{Deformer, FrameStats, YarnOutput};
use crate::mesh::{FACE_POLY_LEN, FacePoly};

/// Scalars per face in the GPU face buffer: the 48 of [`FacePoly`], the skip flag, padding.
pub const GPU_FACE_STRIDE: usize = 52;
const _: () = assert!(FACE_POLY_LEN + 4 == GPU_FACE_STRIDE);

const WORKGROUP: u32 = 64;
/// Workgroups per dispatch row (the x limit of dispatches is 65535).
const ROW_GROUPS: u32 = 32768;

/// Why the GPU back end is unavailable or failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter was found.
    #[error(
        "no GPU adapter found (wgpu: {0}); install a Vulkan driver such as Mesa's lavapipe (mesa-vulkan-drivers) or use the CPU back end"
    )]
    NoAdapter(String),
    /// The device could not be created.
    #[error("GPU device request failed on {adapter}: {message}")]
    Device {
        /// Adapter description.
        adapter: String,
        /// wgpu's message.
        message: String,
    },
    /// A buffer is larger than the device allows.
    #[error("GPU buffer {name} needs {bytes} bytes, the device allows {limit}")]
    TooLarge {
        /// Buffer name.
        name: &'static str,
        /// Bytes needed.
        bytes: u64,
        /// Device limit.
        limit: u64,
    },
    /// Mapping or polling failed.
    #[error("GPU read-back failed: {0}")]
    Readback(String),
    /// The CPU side failed (mesh stage).
    #[error(transparent)]
    Deform(#[from] crate::error::DeformError),
}

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
    bind_group: wgpu::BindGroup,
    params: wgpu::Buffer,
    faces: wgpu::Buffer,
    out: wgpu::Buffer,
    staging: wgpu::Buffer,
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

impl GpuDeformer {
    /// Requests an adapter and device and uploads the static data of `cpu`.
    pub fn new(cpu: &Deformer<f32>) -> Result<Self, GpuError> {
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
        let e = cpu.embedding();
        let db = cpu.database();
        let n = e.len();
        let n_tile = db.n_vertices();
        let max_binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
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
        check("texels", (db.texels().len() * 16) as u64)?;
        check("vertices", (n * 16) as u64)?;
        check("output", (n * 16) as u64)?;
        check("faces", (cpu.mesh().n_faces() * GPU_FACE_STRIDE * 4) as u64)?;

        let mut bytes = Vec::new();
        let upload = |label: &str, data: &[u8], extra| {
            let buffer = storage(&device, label, data.len(), extra);
            queue.write_buffer(&buffer, 0, data);
            buffer
        };
        bytes.clear();
        for k in 0..n {
            for word in [
                e.triangle[k],
                e.tile_vertex[k],
                e.du[k].to_bits(),
                e.dv[k].to_bits(),
            ] {
                bytes.extend_from_slice(&word.to_le_bytes());
            }
        }
        let vin = upload("yarn vertices", &bytes, wgpu::BufferUsages::empty());
        f32_bytes(e.height.iter().copied(), &mut bytes);
        let vheight = upload("yarn heights", &bytes, wgpu::BufferUsages::empty());
        f32_bytes(db.texels().iter().flatten().copied(), &mut bytes);
        let texels = upload("database", &bytes, wgpu::BufferUsages::empty());
        f32_bytes(
            cpu.rest_displacements()
                .iter()
                .flatten()
                .copied()
                .chain(cpu.twists().iter().flat_map(|&t| [t, 0.0, 0.0, 0.0])),
            &mut bytes,
        );
        let tile_data = upload("pattern tables", &bytes, wgpu::BufferUsages::empty());
        let faces = storage(
            &device,
            "faces",
            cpu.mesh().n_faces() * GPU_FACE_STRIDE * 4,
            wgpu::BufferUsages::empty(),
        );
        let out = storage(&device, "output", n * 16, wgpu::BufferUsages::COPY_SRC);
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
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("deform.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("deform.wgsl").into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("deform"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let layout = pipeline.get_bind_group_layout(0);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("deform"),
            layout: &layout,
            entries: &[
                (0, &params),
                (1, &vin),
                (2, &vheight),
                (3, &texels),
                (4, &tile_data),
                (5, &faces),
                (6, &out),
            ]
            .map(|(binding, buffer)| wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            }),
        });
        let [sx, sa, sy] = db.shape();
        Ok(Self {
            device,
            queue,
            pipeline,
            bind_group,
            params,
            faces,
            out,
            staging,
            n,
            n_tile,
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
        let groups = (self.n as u32).div_ceil(WORKGROUP).max(1);
        let (gx, gy) = (groups.min(ROW_GROUPS), groups.div_ceil(ROW_GROUPS));
        self.write_params(flags, cpu.eigen_floor(), gx * WORKGROUP);
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
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        encoder.copy_buffer_to_buffer(&self.out, 0, &self.staging, 0, self.out.size());
        self.queue.submit([encoder.finish()]);
        let slice = self.staging.slice(..);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            sender.send(r).ok();
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        receiver
            .recv()
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let mut nonfinite = 0;
        {
            let view = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            let out = &mut self.output;
            for (k, chunk) in view.chunks_exact(16).take(self.n).enumerate() {
                let v = [0, 4, 8, 12].map(|o| {
                    f32::from_le_bytes([chunk[o], chunk[o + 1], chunk[o + 2], chunk[o + 3]])
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
        self.staging.unmap();
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

    fn write_params(&mut self, flags: u32, eigen_floor: f32, row: u32) {
        let mut words: Vec<u32> = Vec::with_capacity(PARAMS_BYTES / 4);
        words.extend([
            self.n as u32,
            flags,
            self.n_tile as u32,
            eigen_floor.to_bits(),
        ]);
        words.extend([self.shape[0], self.shape[1], self.shape[2], row]);
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
        self.bytes.clear();
        for w in words {
            self.bytes.extend_from_slice(&w.to_le_bytes());
        }
        self.queue.write_buffer(&self.params, 0, &self.bytes);
    }
}

/// Size of the `Params` uniform: 4 vec4 + 24 vec4 of axes.
const PARAMS_BYTES: usize = (4 + 24) * 16;

/// Which back end runs the vertex stage.
#[derive(Debug)]
pub enum Backend {
    /// rayon on the CPU.
    Cpu,
    /// wgpu compute shader.
    Gpu(Box<GpuDeformer>),
}

impl Backend {
    /// The GPU when an adapter exists (printing which), else the CPU with a message saying
    /// why.
    pub fn auto(cpu: &Deformer<f32>) -> (Self, String) {
        match GpuDeformer::new(cpu) {
            Ok(gpu) => {
                let message = format!("GPU back end on {}", gpu.adapter());
                (Backend::Gpu(Box::new(gpu)), message)
            }
            Err(e) => (
                Backend::Cpu,
                format!(
                    "CPU back end ({} rayon threads): {e}",
                    rayon::current_num_threads()
                ),
            ),
        }
    }
}
