//! The error type of every writer and reader in this crate.

use std::path::PathBuf;

/// Errors of writing geometry, images and tables, or of reading tables and meshes.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// An option is out of range.
    #[error("invalid {name}: {message}")]
    Option {
        /// The option's name.
        name: &'static str,
        /// What was expected and found.
        message: String,
    },
    /// Inconsistent input (e.g. polylines whose arrays do not match).
    #[error("{0}")]
    Invalid(String),
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
    /// A CSV table is malformed.
    #[error("{source_name}:{line}: {message}")]
    Csv {
        /// The file (or other source) name.
        source_name: String,
        /// 1-based line.
        line: u64,
        /// What was expected and found.
        message: String,
    },
}

/// `Result` with [`OutputError`].
pub type Result<T> = std::result::Result<T, OutputError>;
