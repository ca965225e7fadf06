//! The commit this binary is built from: `FMSR_BUILD_COMMIT` (`git rev-parse
//! HEAD` of this crate's checkout) and `FMSR_BUILD_DIRTY` (`1` when tracked
//! files differed from it), read by `Provenance`, so a run names the code that
//! ran even when the binary runs from another checkout. Set only when this
//! crate's directory is the top of a git checkout (not for a packaged crate,
//! nor one vendored inside another repository).
//!
//! Only with the `mujoco` feature: an rpath to MuJoCo's library directory
//! (`MUJOCO_DYNAMIC_LINK_DIR`, which `.cargo/config.toml` sets to
//! `target/mujoco/lib` and `scripts/setup_mujoco.sh` fills) in the `fmsr`
//! binary, its examples and benches, so `target/release/fmsr` built with
//! `--features mujoco` starts without `LD_LIBRARY_PATH`.

use std::path::{Path, PathBuf};
use std::process::Command;

/// `git ARGS` in this crate's directory, without taking the index lock
/// (`--no-optional-locks`: `git status` must not rewrite the index it watches).
fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").arg("--no-optional-locks").args(args).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

/// The build's commit, where this crate is the top of its checkout.
fn build_commit() {
    let Some(manifest) = std::env::var_os("CARGO_MANIFEST_DIR").map(PathBuf::from) else { return };
    let top = git(&["rev-parse", "--show-toplevel"]).map(PathBuf::from);
    let same = |a: &Path, b: &Path| a.canonicalize().ok().is_some_and(|a| b.canonicalize().ok() == Some(a));
    if !top.is_some_and(|top| same(&top, &manifest)) {
        return;
    }
    let (Some(commit), Some(git_dir)) = (git(&["rev-parse", "HEAD"]), git(&["rev-parse", "--absolute-git-dir"])) else {
        return;
    };
    // Again when HEAD moves, the index changes (a commit, an add) or a source changes.
    for watched in ["HEAD", "index", "packed-refs", "refs/heads"] {
        let path = Path::new(&git_dir).join(watched);
        if path.exists() {
            println!("cargo:rerun-if-changed={}", path.display());
        }
    }
    for dir in ["src", "fmsr-core/src", "fmsr-nn/src", "fmsr-envs/src", "fmsr-graph/src", "Cargo.toml", "Cargo.lock"] {
        if manifest.join(dir).exists() {
            println!("cargo:rerun-if-changed={dir}");
        }
    }
    println!("cargo:rustc-env=FMSR_BUILD_COMMIT={commit}");
    if let Some(status) = git(&["status", "--porcelain", "--untracked-files=no"]) {
        println!("cargo:rustc-env=FMSR_BUILD_DIRTY={}", u8::from(!status.is_empty()));
    }
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    build_commit();
    if std::env::var_os("CARGO_FEATURE_MUJOCO").is_none() {
        return;
    }
    let Some(dir) = std::env::var_os("MUJOCO_DYNAMIC_LINK_DIR").map(PathBuf::from) else {
        // mujoco-rs' own build script explains what is missing.
        return;
    };
    let dir = dir.canonicalize().unwrap_or(dir);
    for kind in ["bins", "examples", "benches", "tests"] {
        println!("cargo:rustc-link-arg-{kind}=-Wl,-rpath,{}", dir.display());
    }
}
