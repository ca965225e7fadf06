//! The `fmsr` binary in tests: the tiny config, a run trained on it, a command's output.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The `fmsr` binary cargo built for the integration tests.
pub const FMSR: &str = env!("CARGO_BIN_EXE_fmsr");

/// The tiny config (`super::tiny_config_text`) with `extra` appended, written into `dir`.
pub fn tiny_config(dir: &Path, extra: &str) -> PathBuf {
    let path = dir.join("tiny.toml");
    std::fs::write(&path, format!("{}\n{extra}", super::tiny_config_text())).unwrap();
    path
}

/// A run of the tiny config trained for one epoch in `dir/run`.
pub fn trained_tiny_run(dir: &Path) -> PathBuf {
    trained_run(dir, &tiny_config(dir, ""))
}

/// A run of `config` trained in `dir/run`.
pub fn trained_run(dir: &Path, config: &Path) -> PathBuf {
    let run = dir.join("run");
    let out = fmsr(&["train", "--config", config.to_str().unwrap(), "--out", run.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out));
    run
}

/// Runs `fmsr` with `args` to its end.
pub fn fmsr(args: &[&str]) -> std::process::Output {
    Command::new(FMSR).args(args).env("RUST_BACKTRACE", "0").output().unwrap()
}

/// stdout and stderr of a finished command.
pub fn text(out: &std::process::Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}
