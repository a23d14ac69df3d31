//! The learning crate's error type: every failure names the file or field and says what to do.

use std::path::PathBuf;

/// What can go wrong while loading data, training, checkpointing or evaluating.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// A dataset or lab folder could not be read.
    #[error(transparent)]
    Data(#[from] tacsim_data::DataError),
    /// A file could not be read or written.
    #[error("{path}: could not {action}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What was attempted ("read", "write", ...).
        action: &'static str,
        /// The cause.
        source: std::io::Error,
    },
    /// A configuration value is out of range or inconsistent.
    #[error("{field}: {reason}")]
    Config {
        /// The field, as spelled in the config file or on the command line.
        field: String,
        /// Why it is refused and what to use instead.
        reason: String,
    },
    /// A checkpoint or run directory is missing, damaged or from another run.
    #[error("{path}: {reason}")]
    Checkpoint {
        /// The file or directory.
        path: PathBuf,
        /// What is wrong and what to do.
        reason: String,
    },
    /// The data cannot feed the requested training (for example no paired poses).
    #[error("{0}")]
    Insufficient(String),
    /// Training was stopped on request after saving a checkpoint.
    #[error("training stopped; a checkpoint is saved in {dir}: rerun the same command with --resume to continue")]
    Interrupted {
        /// The run directory.
        dir: PathBuf,
    },
    /// An image metric failed (mismatched sizes).
    #[error(transparent)]
    Metric(#[from] crate::metrics::MetricError),
}

impl ModelError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, action: &'static str, source: std::io::Error) -> Self {
        Self::Io { path: path.into(), action, source }
    }

    /// A refused configuration value.
    pub fn config(field: impl Into<String>, reason: impl Into<String>) -> Self {
        Self::Config { field: field.into(), reason: reason.into() }
    }

    /// A checkpoint problem.
    pub fn checkpoint(path: impl Into<PathBuf>, reason: impl Into<String>) -> Self {
        Self::Checkpoint { path: path.into(), reason: reason.into() }
    }
}

/// Result with [`ModelError`].
pub type Result<T, E = ModelError> = std::result::Result<T, E>;
