//! How a report names its runs: by the path from the report's directory to
//! the run (a run directory or a policy file), as a Markdown link.
//!
//! A report is a record that travels: it is committed beside the runs it
//! covers, read on another machine or moved with them. A path as given on the
//! command line names one machine's checkout when it is absolute
//! (`/work/main/pretrained/...`), and a relative one is relative to wherever
//! `fmsr report` ran, not to the summary. The path from the report's own
//! directory is neither: its links work wherever the report and the runs move
//! together.

use std::path::{Path, PathBuf};

use crate::experiment::ExperimentError;

/// Names runs by their path from one report directory.
#[derive(Debug, Clone)]
pub(crate) struct RunLinks {
    /// The report's directory, absolute and with its links resolved.
    base: PathBuf,
}

impl RunLinks {
    /// For the report written into `out`, which exists.
    pub(crate) fn new(out: &Path) -> Result<Self, ExperimentError> {
        let base =
            std::fs::canonicalize(out).map_err(|source| ExperimentError::Io { path: out.to_path_buf(), source })?;
        Ok(Self { base })
    }

    /// The path from the report's directory to `run`, with `/` between its
    /// parts on every platform. A run that cannot be resolved (no longer
    /// there) is made absolute without resolving links; one on another
    /// drive, with no relative path to it, keeps the path as given.
    pub(crate) fn path(&self, run: &Path) -> String {
        let absolute = std::fs::canonicalize(run).or_else(|_| std::path::absolute(run));
        let relative = absolute.ok().and_then(|a| pathdiff::diff_paths(a, &self.base));
        let Some(relative) = relative else { return run.display().to_string() };
        let parts: Vec<_> = relative.components().map(|c| c.as_os_str().to_string_lossy()).collect();
        if parts.is_empty() { ".".to_owned() } else { parts.join("/") }
    }

    /// `[path](path)`, the path as [`RunLinks::path`], fit for a table cell:
    /// a target with spaces or brackets is written `<...>`, and `|` escaped.
    /// A run that holds the report (the main job writes its report into the
    /// run, whose path from there is `..`) is shown by its own name.
    pub(crate) fn link(&self, run: &Path) -> String {
        let path = self.path(run).replace('|', "\\|");
        let text = if path.split('/').all(|part| part == ".." || part == ".") {
            let resolved = std::fs::canonicalize(run).unwrap_or_else(|_| run.to_path_buf());
            resolved.file_name().map_or_else(|| path.clone(), |n| n.to_string_lossy().replace('|', "\\|"))
        } else {
            path.clone()
        };
        if path.contains(|c: char| c.is_whitespace() || "()<>".contains(c)) {
            format!("[{text}](<{path}>)")
        } else {
            format!("[{text}]({path})")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Guards the report's names of its runs (regression): `fmsr report` over
    // runs given by absolute paths printed them as given, so the committed
    // summary of the paper-budget pair named `/work/main/pretrained/...`, one
    // machine's checkout, and none of its run names was a working link.
    #[test]
    fn runs_are_named_from_the_report_whatever_path_was_given() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("docs/results/report");
        let policy = tmp.path().join("pretrained/egg/policy.fmsr");
        std::fs::create_dir_all(&out).unwrap();
        std::fs::create_dir_all(policy.parent().unwrap()).unwrap();
        std::fs::write(&policy, b"").unwrap();
        let links = RunLinks::new(&out).unwrap();
        assert_eq!(links.path(&policy), "../../../pretrained/egg/policy.fmsr");
        assert_eq!(links.link(&policy), "[../../../pretrained/egg/policy.fmsr](../../../pretrained/egg/policy.fmsr)");
        // The same run given through a detour names the same path.
        let detour = tmp.path().join("docs/../pretrained/./egg/policy.fmsr");
        assert_eq!(links.path(&detour), "../../../pretrained/egg/policy.fmsr");
        // A run inside the report's directory, and the directory itself.
        let inside = out.join("run a");
        std::fs::create_dir(&inside).unwrap();
        assert_eq!(links.link(&inside), "[run a](<run a>)");
        assert_eq!(links.path(&out), ".");
        // A run that holds the report (the main job's) is shown by its name.
        let run = tmp.path().join("runs/egg quick");
        std::fs::create_dir_all(run.join("report")).unwrap();
        let links = RunLinks::new(&run.join("report")).unwrap();
        assert_eq!(links.link(&run), "[egg quick](..)");
    }

    #[test]
    fn a_run_no_longer_there_is_still_named_from_the_report() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("report");
        std::fs::create_dir(&out).unwrap();
        let links = RunLinks::new(&out).unwrap();
        let base = std::fs::canonicalize(tmp.path()).unwrap();
        assert_eq!(links.path(&base.join("gone/run|1")), "../gone/run|1");
        assert_eq!(links.link(&base.join("gone/run|1")), "[../gone/run\\|1](../gone/run\\|1)");
    }
}
