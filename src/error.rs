//! The error of the `fmsr` crate: [`ExperimentError`], one enum for
//! experiments, runs, their files and the command line.

use std::path::PathBuf;

use fmsr_core::CoreError;

/// Errors of experiments and runs.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// A command-line argument is wrong or contradicts the run it names.
    #[error("argument `{arg}`: {reason}")]
    Cli {
        /// The argument (`--out`, `--rescue`, ...).
        arg: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// An algorithm or a task cannot be registered under its name
    /// ([`crate::algorithms::register`], [`crate::tasks::register`]).
    #[error("cannot register `{name}`: {reason}")]
    Register {
        /// The rule's or the task's name.
        name: String,
        /// Why not.
        reason: String,
    },
    /// A configuration value is wrong. Where another error says why (the
    /// TOML decoder's, a device's), `reason` says what was being done and
    /// `source` holds that error ([`ExperimentError::config_source`]).
    #[error("config: `{key}`: {reason}")]
    Config {
        /// The key.
        key: String,
        /// What is wrong.
        reason: String,
        /// The error behind `reason`, if another one said it.
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// A file could not be parsed: a TOML experiment (unknown key, wrong
    /// type, syntax), a policy file, a run's JSON records, an event file.
    /// Where a decoder said why (TOML's, JSON's, the policy file's framing),
    /// `message` says what was being read and `source` holds that error,
    /// which names the key and line ([`ExperimentError::parse_source`]).
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong, or what was being read when `source` failed.
        message: String,
        /// The decoder's error behind `message`, if one said it.
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// Reading or writing a run file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A value that only the environment can check (agents, features, graph,
    /// mixing matrix) is wrong.
    #[error("config: `{key}`: {source}")]
    Invalid {
        /// The key.
        key: &'static str,
        /// What is wrong.
        #[source]
        source: CoreError,
    },
    /// Another process is writing the run directory (`fmsr train` holds its lock).
    #[error(
        "{dir} is being written by another process ({holder}): one `fmsr train` per run directory; \
         wait for it to end, or stop it, before training or resuming this run"
    )]
    RunLocked {
        /// The run directory.
        dir: PathBuf,
        /// Who holds it, as the holder wrote it into the lock file.
        holder: String,
    },
    /// A directory given as a run or policy holds neither, or no trained run.
    #[error("{path}: {reason}")]
    NotARun {
        /// The directory or file given.
        path: PathBuf,
        /// What it lacks.
        reason: String,
    },
    /// A file's contents could not be encoded (JSON, TOML, the policy file's framing).
    #[error("encoding {what}: {reason}")]
    Encode {
        /// The file being written (`eval.json`, `provenance.json`, ...).
        what: &'static str,
        /// The encoder's message.
        reason: String,
    },
    /// A report's figure could not be plotted.
    #[error("plotting {path}: {reason}")]
    Plot {
        /// The figure's file.
        path: PathBuf,
        /// The plotting library's message.
        reason: String,
    },
    /// A frame or an image file could not be drawn or encoded.
    #[error("rendering {what}: {reason}")]
    Render {
        /// What was being drawn or written.
        what: String,
        /// Why it failed.
        reason: String,
    },
    /// What a command was doing when another error stopped it.
    #[error("{what}: {source}")]
    Context {
        /// What was being done (`reading the run's config.toml`).
        what: String,
        /// The error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A core error (trainer, checkpoint, graph).
    #[error(transparent)]
    Core(#[from] CoreError),
    /// An environment error.
    #[error(transparent)]
    Env(#[from] fmsr_envs::EnvError),
    /// A learner error.
    #[error(transparent)]
    Nn(#[from] fmsr_nn::NnError),
}

impl ExperimentError {
    /// [`ExperimentError::Config`]: `reason` says what is wrong with `key`.
    pub fn config(key: impl Into<String>, reason: impl Into<String>) -> Self {
        Self::Config { key: key.into(), reason: reason.into(), source: None }
    }

    /// [`ExperimentError::Config`] caused by another error: `reason` says
    /// what was wrong or being done, `source` why (an error's chain, as the
    /// `fmsr` command prints it, says both).
    pub fn config_source(
        key: impl Into<String>,
        reason: impl Into<String>,
        source: impl Into<Box<dyn std::error::Error + Send + Sync>>,
    ) -> Self {
        Self::Config { key: key.into(), reason: reason.into(), source: Some(source.into()) }
    }

    /// [`ExperimentError::Parse`]: `message` says what is wrong with the file at `path`.
    pub fn parse(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Self::Parse { path: path.into(), message: message.into(), source: None }
    }

    /// [`ExperimentError::Parse`] caused by a decoder's error: `message` says
    /// what was being read, `source` what the decoder found (with its key
    /// and line, where it knows them).
    pub fn parse_source(
        path: impl Into<PathBuf>,
        message: impl Into<String>,
        source: impl Into<Box<dyn std::error::Error + Send + Sync>>,
    ) -> Self {
        Self::Parse { path: path.into(), message: message.into(), source: Some(source.into()) }
    }
}

#[cfg(test)]
mod tests {
    use std::error::Error as _;
    use std::path::Path;

    use super::ExperimentError;
    use crate::experiment::ExperimentConfig;

    // Guards config errors that keep the decoder's error: an unknown key or
    // a wrong type in a TOML experiment is an `ExperimentError::Parse`
    // naming the file, whose source is TOML's own error, with the key and
    // its line, and not a copy of its text.
    #[test]
    fn parse_errors_keep_the_decoders_error() {
        let text = std::fs::read_to_string("configs/egg_dense_fmsr_is.toml").unwrap();
        let path = Path::new("bad.toml");
        for (bad, names) in [
            (text.replace("[trainer]\n", "[trainer]\nseeds = 3\n"), "seeds"),
            (text.replace("[trainer]\n", "[trainer]\nepochs = \"many\"\n"), "epochs"),
            (format!("{text}\n[trainer\n"), "line"),
        ] {
            let err = ExperimentConfig::from_toml(&bad, path).unwrap_err();
            let ExperimentError::Parse { path: at, source: Some(source), .. } = &err else {
                panic!("not a parse error with its source: {err:?}")
            };
            assert_eq!(at, path);
            assert!(source.downcast_ref::<toml::de::Error>().is_some(), "{source:?}");
            assert!(source.to_string().contains(names), "{source}");
            assert!(err.source().is_some_and(|s| s.to_string() == source.to_string()));
            assert!(!err.to_string().contains(&source.to_string()), "said twice: {err}");
        }
    }
}
