//! The error type of fmsr-core.

use thiserror::Error;

/// Everything that can go wrong in fmsr-core, each variant naming what is wrong.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum CoreError {
    /// An agent partition does not cover the joint action exactly once.
    #[error(
        "action slot {slot} is owned by {owners} agents (each of the {action_dim} slots must be owned by exactly one)"
    )]
    ActionPartition {
        /// The offending slot of the joint action.
        slot: usize,
        /// How many agents claim it.
        owners: usize,
        /// Length of the joint action.
        action_dim: usize,
    },
    /// A vector has the wrong length.
    #[error("{what}: expected length {expected}, found {found}")]
    Dimension {
        /// What the vector is (e.g. "joint action").
        what: &'static str,
        /// The length the spec requires.
        expected: usize,
        /// The length that was given.
        found: usize,
    },
    /// A value is NaN or infinite.
    #[error("{what}: non-finite value at index {index}")]
    NotFinite {
        /// What the vector is.
        what: &'static str,
        /// Position of the first non-finite value.
        index: usize,
    },
    /// A feature value lies outside [0, 1].
    #[error("feature {feature} at step {step} is {value}, outside [0, 1]")]
    FeatureRange {
        /// Index of the feature.
        feature: usize,
        /// Step within the episode.
        step: usize,
        /// The offending value.
        value: f32,
    },
    /// A configuration value is impossible.
    #[error("invalid value for `{key}`: {reason}")]
    InvalidConfig {
        /// The configuration key.
        key: String,
        /// Why it is rejected.
        reason: String,
    },
    /// An agent named in a configuration does not exist in the environment.
    #[error("unknown agent `{name}` (the environment has: {known})")]
    UnknownAgent {
        /// The name that was not found.
        name: String,
        /// The agents the environment has, comma separated.
        known: String,
    },
    /// A feature named in a configuration does not exist in the environment.
    #[error("unknown feature `{name}` (the environment reports: {known})")]
    UnknownFeature {
        /// The name that was not found.
        name: String,
        /// The features the environment reports, comma separated.
        known: String,
    },
    /// An agent is missing from, or repeated in, a per-agent configuration.
    #[error("agent `{name}` appears {count} times in {what} (must appear exactly once)")]
    AgentCount {
        /// The agent's name.
        name: String,
        /// How often it appears.
        count: usize,
        /// The configuration section.
        what: &'static str,
    },
    /// The replay buffer holds no episodes yet.
    #[error("the replay buffer is empty")]
    EmptyReplay,
    /// An episode has the wrong shape for the buffer.
    #[error("episode has {found} {what}, the buffer expects {expected}")]
    EpisodeShape {
        /// Which part of the episode.
        what: &'static str,
        /// Expected count.
        expected: usize,
        /// Found count.
        found: usize,
    },
    /// A graph or mixing matrix error.
    #[error(transparent)]
    Graph(#[from] fmsr_graph::GraphError),
    /// An error of the environment.
    #[error("environment: {0}")]
    Env(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// An error of the algorithm (its policy or its updates).
    #[error("algorithm: {0}")]
    Algorithm(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A checkpoint or saved file could not be decoded.
    #[error("{path}: corrupt or incompatible file: {reason}")]
    Corrupt {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// A singular value decomposition did not converge.
    #[error("{what}: the SVD of the {rows} x {cols} matrix did not converge")]
    Svd {
        /// What the matrix is.
        what: &'static str,
        /// Its rows.
        rows: usize,
        /// Its columns.
        cols: usize,
    },
}

/// Checks that `values` has `expected` entries, all finite.
pub(crate) fn check_vector(what: &'static str, values: &[f32], expected: usize) -> Result<(), CoreError> {
    if values.len() != expected {
        return Err(CoreError::Dimension { what, expected, found: values.len() });
    }
    if let Some(index) = values.iter().position(|v| !v.is_finite()) {
        return Err(CoreError::NotFinite { what, index });
    }
    Ok(())
}
