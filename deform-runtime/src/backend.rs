//! The back end that runs the per-vertex stage: the CPU (rayon) always, the GPU (wgpu) when
//! the crate is built with its default `gpu` feature.

use crate::deform::{Deformer, FrameStats, YarnOutput};
use crate::error::Result;
#[cfg(feature = "gpu")]
use crate::gpu::GpuDeformer;

/// Which back end runs the vertex stage.
#[derive(Debug)]
pub enum Backend {
    /// rayon on the CPU.
    Cpu,
    /// wgpu compute shader.
    #[cfg(feature = "gpu")]
    Gpu(Box<GpuDeformer>),
}

impl Backend {
    /// The GPU when an adapter exists (saying which), else the CPU with a message saying why.
    pub fn auto(cpu: &Deformer<f32>) -> (Self, String) {
        match Self::gpu(cpu) {
            Ok(gpu) => gpu,
            Err(e) => (
                Backend::Cpu,
                format!(
                    "CPU back end ({} rayon threads): {e}",
                    rayon::current_num_threads()
                ),
            ),
        }
    }

    /// The GPU back end and a message naming the adapter; an error when no adapter exists or
    /// the crate was built without the `gpu` feature.
    pub fn gpu(cpu: &Deformer<f32>) -> Result<(Self, String)> {
        #[cfg(feature = "gpu")]
        {
            let gpu = GpuDeformer::new(cpu).map_err(Box::new)?;
            let message = format!("GPU back end on {}", gpu.adapter());
            Ok((Backend::Gpu(Box::new(gpu)), message))
        }
        #[cfg(not(feature = "gpu"))]
        {
            let _ = cpu;
            Err(crate::error::DeformError::Option {
                name: "backend",
                message: "expected a build with the `gpu` feature (default) for the GPU back end"
                    .into(),
            })
        }
    }

    /// Deforms one frame with this back end.
    pub fn frame(
        &mut self,
        deformer: &mut Deformer<f32>,
        positions: &[[f64; 3]],
    ) -> Result<FrameStats> {
        match self {
            Backend::Cpu => deformer.frame(positions),
            #[cfg(feature = "gpu")]
            Backend::Gpu(gpu) => gpu
                .frame(deformer, positions)
                .map_err(|e| Box::new(e).into()),
        }
    }

    /// The yarn vertices of the last frame.
    pub fn output<'a>(&'a self, deformer: &'a Deformer<f32>) -> &'a YarnOutput<f32> {
        match self {
            Backend::Cpu => deformer.output(),
            #[cfg(feature = "gpu")]
            Backend::Gpu(gpu) => gpu.output(),
        }
    }
}
