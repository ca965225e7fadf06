//! Where a run came from: the commit and build that trained it, recorded in
//! `RUN/provenance.json` when the run starts, carried by its policy file.
//!
//! The commit is the `git` HEAD of the directory `fmsr train` was started in,
//! with `dirty` set when tracked files differed from it, so a result names the
//! code it came from. Outside a git checkout (or without `git`) both are
//! absent, and the record says so rather than guessing.
//!
//! The binary's own commit is recorded beside it (`build_commit`,
//! `build_dirty`, from `build.rs` when the binary was built in a git
//! checkout): where a binary built at one commit runs from a checkout at
//! another (a long run's kept binary, `scripts/lite_arm.sh --bin`), the two
//! differ and the build's is the code that ran. The oldest records have no
//! build commit.

use std::path::Path;
use std::process::Command;

use serde::{Deserialize, Serialize};

/// The commit, build and command of one training run.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, Default)]
pub struct Provenance {
    /// `git rev-parse HEAD` of the working directory (`None`: not a git checkout).
    pub commit: Option<String>,
    /// Whether tracked files had uncommitted changes (`None`: unknown).
    pub dirty: Option<bool>,
    /// The commit the binary was built from (`None`: built outside a git
    /// checkout, or a record older than the field).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub build_commit: Option<String>,
    /// Whether the build's tracked files differed from `build_commit`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub build_dirty: Option<bool>,
    /// The `fmsr` crate version of the binary.
    pub version: String,
    /// The cargo features the binary was built with.
    pub features: Vec<String>,
    /// The command line.
    pub command: Vec<String>,
    /// When the run started (seconds since the Unix epoch).
    pub started_unix: u64,
}

impl Provenance {
    /// This process: the commit of `dir`'s checkout, this build, this command.
    #[must_use]
    pub fn of_this_process(dir: &Path) -> Self {
        let git = |args: &[&str]| {
            Command::new("git")
                .args(args)
                .current_dir(dir)
                .output()
                .ok()
                .filter(|o| o.status.success())
                .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        };
        let commit = git(&["rev-parse", "HEAD"]).filter(|c| !c.is_empty());
        let dirty = commit.as_ref().and(git(&["status", "--porcelain", "--untracked-files=no"])).map(|s| !s.is_empty());
        Self {
            commit,
            dirty,
            build_commit: option_env!("FMSR_BUILD_COMMIT").map(str::to_owned),
            build_dirty: option_env!("FMSR_BUILD_DIRTY").map(|d| d == "1"),
            version: env!("CARGO_PKG_VERSION").into(),
            features: build_features(),
            command: std::env::args().collect(),
            started_unix: std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs()),
        }
    }

    /// The commit in words: a short hash, `+dirty` when it had changes, or `unknown`.
    ///
    /// ```
    /// use fmsr::provenance::Provenance;
    /// let p = Provenance { commit: Some("c2584c1a9f".into()), dirty: Some(true), ..Default::default() };
    /// assert_eq!(p.commit_label(), "c2584c1+dirty");
    /// assert_eq!(Provenance::default().commit_label(), "unknown");
    /// ```
    #[must_use]
    pub fn commit_label(&self) -> String {
        match &self.commit {
            Some(c) => format!("{}{}", &c[..c.len().min(7)], if self.dirty == Some(true) { "+dirty" } else { "" }),
            None => "unknown".into(),
        }
    }
}

/// The optional cargo features compiled into this binary.
fn build_features() -> Vec<String> {
    [
        ("mujoco", cfg!(feature = "mujoco")),
        ("mpi", cfg!(feature = "mpi")),
        ("wgpu", cfg!(feature = "wgpu")),
        ("vulkan", cfg!(feature = "vulkan")),
        ("cuda", cfg!(feature = "cuda")),
    ]
    .into_iter()
    .filter(|(_, on)| *on)
    .map(|(name, _)| name.to_owned())
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_from_before_the_build_commit_reads_and_writes_back_the_same() {
        let old = r#"{"commit":"49a82c6","dirty":false,"version":"0.1.0","features":["mujoco"],"command":["fmsr"],"started_unix":1}"#;
        let p: Provenance = serde_json::from_str(old).unwrap();
        assert_eq!((p.build_commit.as_deref(), p.build_dirty), (None, None));
        assert_eq!(serde_json::to_string(&p).unwrap(), old);
    }

    #[test]
    fn this_process_names_the_commit_it_was_built_from() {
        let p = Provenance::of_this_process(Path::new("."));
        assert_eq!(p.build_commit.as_deref(), option_env!("FMSR_BUILD_COMMIT"));
        if let Some(commit) = &p.build_commit {
            assert_eq!(commit.len(), 40, "{commit}");
            assert!(commit.bytes().all(|b| b.is_ascii_hexdigit()), "{commit}");
            assert!(p.build_dirty.is_some());
        }
    }
}
