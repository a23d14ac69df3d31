//! The closed loop's error type: what went wrong, naming the scenario file or field.

use std::path::PathBuf;

use tacsim_sim::SimError;

/// Errors of loading and running scenarios.
#[derive(Debug, thiserror::Error)]
pub enum ExploreError {
    /// A scenario file that cannot be read.
    #[error("reading {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A scenario whose text or values are wrong: `what` names the file or scenario and the
    /// field, `reason` the value and the accepted range.
    #[error("{what}: {reason}")]
    Scenario {
        /// File or scenario, and field.
        what: String,
        /// What is wrong and what is accepted.
        reason: String,
    },
    /// The simulator refused (a sensor, a stimulus, a pose), in the context `what`.
    #[error("{what}: {source}")]
    Sim {
        /// The scenario and field.
        what: String,
        /// The cause.
        source: SimError,
    },
    /// The simulator refused, its message saying what.
    #[error(transparent)]
    Simulator(#[from] SimError),
    /// Learned perception failed (loading or reading its networks).
    #[error("{what}: {reason}")]
    Perception {
        /// The scenario and field.
        what: String,
        /// The cause, with what to do.
        reason: String,
    },
}

impl ExploreError {
    /// A bad value of `what` (file or scenario, and field).
    pub fn scenario(what: impl Into<String>, reason: impl Into<String>) -> Self {
        Self::Scenario { what: what.into(), reason: reason.into() }
    }

    /// The error with `context` (a scenario, a file) put before what it names; errors that
    /// name nothing (I/O, the simulator's own) are kept as they are.
    pub fn within(self, context: &str) -> Self {
        match self {
            Self::Scenario { what, reason } => Self::Scenario { what: format!("{context}: {what}"), reason },
            Self::Perception { what, reason } => Self::Perception { what: format!("{context}: {what}"), reason },
            e => e,
        }
    }

    /// A simulator error in the context `what`.
    pub fn sim(what: impl Into<String>) -> impl FnOnce(SimError) -> Self {
        let what = what.into();
        move |source| Self::Sim { what, source }
    }
}

/// Result with [`ExploreError`].
pub type Result<T, E = ExploreError> = std::result::Result<T, E>;
