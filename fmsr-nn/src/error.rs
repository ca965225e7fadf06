//! The error type of fmsr-nn.

use thiserror::Error;

/// Everything that can go wrong in fmsr-nn, each variant naming what is wrong.
///
/// No public function of this crate panics on bad input; it returns one of these.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum NnError {
    /// A configuration value is impossible.
    #[error("invalid value for `{key}`: {reason}")]
    InvalidConfig {
        /// The configuration key.
        key: &'static str,
        /// Why it is rejected.
        reason: String,
    },
    /// An input (batch, actor inputs, parameters) has the wrong length.
    #[error("{what}: expected length {expected}, found {found}")]
    Dimension {
        /// What the input is (e.g. "batch.obs").
        what: String,
        /// The length the layout requires.
        expected: usize,
        /// The length that was given.
        found: usize,
    },
    /// An input holds NaN or an infinity.
    #[error("{what}: non-finite value at index {index}")]
    NotFinite {
        /// What the input is.
        what: String,
        /// Position of the first non-finite value.
        index: usize,
    },
    /// An agent index is out of range.
    #[error("agent {agent} out of range for a learner of {agents} agents")]
    UnknownAgent {
        /// The index that was asked for.
        agent: usize,
        /// Number of agents of the learner.
        agents: usize,
    },
    /// Storing in or sampling from the replay buffer failed.
    #[error("replay buffer: {reason}")]
    Replay {
        /// What went wrong.
        reason: String,
    },
    /// The sharing configuration does not fit the learner.
    #[error("information sharing: {reason}")]
    Sharing {
        /// What does not fit.
        reason: String,
    },
    /// The mixing step of `fmsr-graph` failed.
    #[error("mixing {what}: {source}")]
    Mixing {
        /// What was being mixed.
        what: &'static str,
        /// The graph error.
        #[source]
        source: fmsr_graph::GraphError,
    },
    /// A tensor could not be read back from the backend.
    #[error("backend: could not read {what}: {reason}")]
    Backend {
        /// What was being read.
        what: &'static str,
        /// The backend's message.
        reason: String,
    },
    /// A device string names a device this build or this machine does not have.
    #[error("device `{device}`: {reason}; devices here: {available}")]
    Device {
        /// The device string as given.
        device: String,
        /// Why it cannot be used.
        reason: String,
        /// The device strings this build and machine can use, comma separated.
        available: String,
    },
    /// Saved state bytes are malformed (wrong magic, truncated, checksum mismatch).
    #[error("corrupted learner state at byte {offset}: {reason}")]
    CorruptState {
        /// Byte offset where reading failed.
        offset: usize,
        /// What is wrong.
        reason: String,
    },
    /// Saved state is well formed but belongs to a learner of another shape.
    #[error("learner state does not match this learner: {what} is {found} in the state but {expected} here")]
    StateMismatch {
        /// Which part differs.
        what: String,
        /// The value of this learner.
        expected: String,
        /// The value in the state.
        found: String,
    },
}

/// Checks the length of `values` and that each is finite.
pub(crate) fn check_values(what: impl Fn() -> String, values: &[f32], expected: usize) -> Result<(), NnError> {
    if values.len() != expected {
        return Err(NnError::Dimension { what: what(), expected, found: values.len() });
    }
    if let Some(index) = values.iter().position(|v| !v.is_finite()) {
        return Err(NnError::NotFinite { what: what(), index });
    }
    Ok(())
}
