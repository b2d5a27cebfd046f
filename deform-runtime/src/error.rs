//! Typed errors of the deformer library.

use std::path::PathBuf;

/// Everything that can go wrong when loading inputs or setting up a deformation.
#[derive(Debug, thiserror::Error)]
pub enum DeformError {
    /// The displacement database could not be read or is malformed.
    #[error(transparent)]
    Database(#[from] yarn_pattern::madypg::DatabaseError),
    /// The pattern (`.pyp`) could not be read or is malformed.
    #[error(transparent)]
    Pattern(#[from] yarn_pattern::pyp::PypError),
    /// The pattern tile is inconsistent.
    #[error("invalid pattern tile: {0}")]
    Tile(#[from] yarn_pattern::tile::TileError),
    /// Database and pattern do not belong together.
    #[error(
        "database/pattern mismatch: the database has {database} vertices per sample, the pattern has {pattern} vertices"
    )]
    VertexCountMismatch {
        /// Vertices in the database (rows / samples per vertex).
        database: usize,
        /// Vertices in the pattern.
        pattern: usize,
    },
    /// The database contains NaN or infinite displacements.
    #[error(
        "database row {row} (vertex {vertex}) is not finite: expected finite (Δx, Δy, Δz, Δθ), found {values:?}"
    )]
    NonFiniteData {
        /// Row index.
        row: usize,
        /// Pattern vertex of that row.
        vertex: usize,
        /// The row.
        values: [f32; 4],
    },
    /// The GPU back end is unavailable or failed.
    #[cfg(feature = "gpu")]
    #[error(transparent)]
    Gpu(#[from] Box<GpuError>),
    /// Output (geometry, image) could not be written.
    #[error(transparent)]
    Output(yarn_output::OutputError),
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// A mesh file is malformed.
    #[error("{}:{line}: {message}", path.display())]
    Mesh {
        /// The file.
        path: PathBuf,
        /// 1-based line (0 when the problem is not tied to a line).
        line: usize,
        /// What was expected and what was found.
        message: String,
    },
    /// A frame of an animation does not match the rest mesh.
    #[error("{}: {message}", path.display())]
    FrameMismatch {
        /// The frame file.
        path: PathBuf,
        /// What differs.
        message: String,
    },
    /// An option value is out of range.
    #[error("invalid option {name}: {message}")]
    Option {
        /// Option name.
        name: &'static str,
        /// What is wrong.
        message: String,
    },
    /// Nothing of the pattern lies on the mesh.
    #[error(
        "no yarn vertex lies on the mesh (UV area {uv_area:.3e} m², pattern period {period:?} m): check the UV scale"
    )]
    EmptyEmbedding {
        /// Total UV area of the mesh (m², after scaling).
        uv_area: f64,
        /// Pattern period (m).
        period: [f64; 2],
    },
}

/// Shorthand for results of this crate.
pub type Result<T, E = DeformError> = std::result::Result<T, E>;

/// Why the GPU back end ([`crate::gpu`]) is unavailable or failed.
#[cfg(feature = "gpu")]
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
    /// Invalid [`crate::gpu::Chunking`].
    #[error("invalid GPU chunking: {0}")]
    Chunking(String),
    /// The CPU side failed (mesh stage).
    #[error(transparent)]
    Deform(#[from] DeformError),
}
