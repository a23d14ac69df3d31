//! The simulator's error type. Every variant names the file (or the in-memory source) and,
//! where it applies, the field, and says what to do next.

use std::path::PathBuf;

/// Where a value came from: a file on disk or a built-in (embedded) source.
pub type Source = String;

/// Errors of the `tacsim-sim` crate.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A file could not be read or written.
    #[error("{path}: {action} failed: {source}")]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// What was being done ("read", "write", "rename into place", ...).
        action: &'static str,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A TOML file does not parse or has unknown / mistyped fields.
    #[error("{source_name}: {message}")]
    Toml {
        /// File name or built-in source.
        source_name: Source,
        /// The parser's message (it names the field and the line).
        message: String,
    },
    /// A parameter is out of its valid range or not finite.
    #[error("{source_name}: field `{field}` {reason}")]
    Invalid {
        /// File name or built-in source.
        source_name: Source,
        /// Dotted field path, e.g. `dome.outer_radius_mm`.
        field: String,
        /// What is wrong and what is allowed.
        reason: String,
    },
    /// A mesh is unusable (empty, non-finite, open, non-manifold, ...).
    #[error("{source_name}: bad mesh: {reason}")]
    Mesh {
        /// File name or built-in source.
        source_name: Source,
        /// What is wrong.
        reason: String,
    },
    /// An image file could not be decoded or encoded.
    #[error("{path}: {reason}")]
    Image {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A sensor cannot be rendered at the requested size (pins merge or leave the image).
    #[error("sensor `{source_name}` cannot be rendered at {size}x{size} px: {reason}")]
    Render {
        /// File name or built-in source of the sensor.
        source_name: Source,
        /// Requested image size (px).
        size: u32,
        /// What goes wrong and how to fix it.
        reason: String,
    },
    /// A named item (shape, preset, ...) does not exist.
    #[error("unknown {kind} `{name}`; known: {known}")]
    Unknown {
        /// What kind of thing was looked up.
        kind: &'static str,
        /// The name asked for.
        name: String,
        /// The names that exist.
        known: String,
    },
    /// A calibration or analysis could not be carried out on the given data.
    #[error("{source_name}: {reason}")]
    Analysis {
        /// The data concerned.
        source_name: Source,
        /// What went wrong.
        reason: String,
    },
    /// A contact solve did not converge.
    #[error(
        "{solver} contact solve did not converge in {iterations} iterations (residual {residual:.3e}); \
             refine the grid or shorten the step"
    )]
    NoConvergence {
        /// Which solve ("normal", "tangential").
        solver: &'static str,
        /// Iterations spent.
        iterations: usize,
        /// Last relative residual.
        residual: f64,
    },
    /// The GPU path (feature `wgpu`) has no device or failed on it.
    #[error("GPU: {0}")]
    Gpu(String),
    /// The finite-element dome (`skin.model = "dome"`) could not be built, read or written.
    #[error("the finite-element dome: {0}")]
    Dome(String),
}

/// Result alias of this crate.
pub type Result<T, E = SimError> = std::result::Result<T, E>;

impl SimError {
    /// Shorthand for [`SimError::Invalid`].
    pub fn invalid(source_name: &str, field: impl Into<String>, reason: impl Into<String>) -> Self {
        SimError::Invalid { source_name: source_name.to_owned(), field: field.into(), reason: reason.into() }
    }

    /// Shorthand for [`SimError::Mesh`].
    pub fn mesh(source_name: &str, reason: impl Into<String>) -> Self {
        SimError::Mesh { source_name: source_name.to_owned(), reason: reason.into() }
    }

    /// Shorthand for [`SimError::Io`].
    pub fn io(path: impl Into<PathBuf>, action: &'static str, source: std::io::Error) -> Self {
        SimError::Io { path: path.into(), action, source }
    }
}

impl From<tacsim_data::DataError> for SimError {
    /// File errors keep their path and action; format errors of the dataset layer become
    /// analysis errors of the `dataset` source.
    fn from(e: tacsim_data::DataError) -> Self {
        match e {
            tacsim_data::DataError::Io { path, action, source } => SimError::Io { path, action, source },
            other => SimError::Analysis { source_name: "dataset".into(), reason: other.to_string() },
        }
    }
}
